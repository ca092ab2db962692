#include "model/table_store.hpp"

#include <cstring>
#include <stdexcept>

namespace ssrfleet::model {
namespace {

// Copies a field's values to `out` and returns the byte after them. A table may have no node (a
// truck no lattice node explains): then both pointers may be null, which memcpy must not see even
// for zero bytes (UBSan found it, fuzzing a stream's resume).
template <class T>
std::byte* put(std::byte* out, const std::vector<T>& values) {
  if (values.empty()) return out;
  std::memcpy(out, values.data(), values.size() * sizeof(T));
  return out + values.size() * sizeof(T);
}

// The slopes' fields, or zeros for a table without them (one read from a state written before
// tables had them: evaluated with its moments fixed, as it was built to be).
std::byte* put_or_zero(std::byte* out, const std::vector<float>& values, std::size_t n) {
  if (values.size() == n) return put(out, values);
  if (!values.empty()) throw std::logic_error("TableStore: a table's slope field has the wrong length");
  if (n > 0) std::memset(out, 0, n * sizeof(float));
  return out + n * sizeof(float);
}

}  // namespace

TableView view_of(const TruckTable& t) {
  // A table without slopes (made by hand, or read from an older state) views them as absent.
  const bool slopes = t.z_mean_slope_m.size() == t.nodes() && t.z_var_slope_m2.size() == t.nodes();
  return {t.k_index.data(), t.kt_index.data(), t.c.data(), t.m.data(), t.b.data(),
          t.z_mean_m.data(), t.z_var_m2.data(), slopes ? t.z_mean_slope_m.data() : nullptr,
          slopes ? t.z_var_slope_m2.data() : nullptr, t.nodes(), t.u_ref};
}

TableStore::TableStore(const std::string& spill_directory) : arena_(spill_directory), index_(spill_directory) {}

void TableStore::append(const TruckTable& t, std::uint32_t site) {
  const std::size_t n = t.nodes();
  record_.resize(n * kBytesPerNode);
  std::byte* out = record_.data();
  out = put(out, t.k_index);
  out = put(out, t.kt_index);
  out = put(out, t.c);
  out = put(out, t.m);
  out = put(out, t.b);
  out = put(out, t.z_mean_m);
  out = put(out, t.z_var_m2);
  out = put_or_zero(out, t.z_mean_slope_m, n);
  put_or_zero(out, t.z_var_slope_m2, n);
  const Entry entry{nodes(), t.u_ref, static_cast<std::uint32_t>(n), site};
  const std::size_t arena_before = arena_.size();
  arena_.append(record_.data(), record_.size());
  try {
    index_.push_back(entry);
  } catch (...) {
    arena_.truncate(arena_before);  // all or nothing
    throw;
  }
}

TableView TableStore::view(std::size_t i) const {
  static_assert(sizeof(std::int32_t) == 4 && sizeof(float) == 4, "every field is 4 bytes a node");
  const Entry& e = index_[i];
  const std::size_t n = e.count;
  const std::byte* p = arena_.data() + e.offset * kBytesPerNode;
  const auto ints = [&](std::size_t field) { return reinterpret_cast<const std::int32_t*>(p + field * n * 4); };
  const auto floats = [&](std::size_t field) { return reinterpret_cast<const float*>(p + field * n * 4); };
  return {ints(0),   ints(1),   floats(2), floats(3), floats(4), floats(5),
          floats(6), floats(7), floats(8), n,         e.u_ref,   e.site};
}

}  // namespace ssrfleet::model
