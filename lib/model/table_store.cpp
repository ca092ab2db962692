#include "model/table_store.hpp"

namespace ssrfleet::model {

TableView view_of(const TruckTable& t) {
  return {t.k_index.data(), t.kt_index.data(), t.c.data(), t.m.data(), t.b.data(),
          t.z_mean_m.data(), t.z_var_m2.data(), t.nodes(), t.u_ref};
}

void TableStore::reserve(std::size_t trucks, std::size_t nodes) {
  auto& c = cols_;
  c.k_index.reserve(nodes);
  c.kt_index.reserve(nodes);
  c.c.reserve(nodes);
  c.m.reserve(nodes);
  c.b.reserve(nodes);
  c.z_mean_m.reserve(nodes);
  c.z_var_m2.reserve(nodes);
  c.offset.reserve(trucks);
  c.count.reserve(trucks);
  c.u_ref.reserve(trucks);
  c.site.reserve(trucks);
}

void TableStore::append(const TruckTable& t, std::uint32_t site) {
  auto& c = cols_;
  c.site.push_back(site);
  c.offset.push_back(c.c.size());
  c.count.push_back(static_cast<std::uint32_t>(t.nodes()));
  c.u_ref.push_back(t.u_ref);
  c.k_index.insert(c.k_index.end(), t.k_index.begin(), t.k_index.end());
  c.kt_index.insert(c.kt_index.end(), t.kt_index.begin(), t.kt_index.end());
  c.c.insert(c.c.end(), t.c.begin(), t.c.end());
  c.m.insert(c.m.end(), t.m.begin(), t.m.end());
  c.b.insert(c.b.end(), t.b.begin(), t.b.end());
  c.z_mean_m.insert(c.z_mean_m.end(), t.z_mean_m.begin(), t.z_mean_m.end());
  c.z_var_m2.insert(c.z_var_m2.end(), t.z_var_m2.begin(), t.z_var_m2.end());
}

TableView TableStore::view(std::size_t i) const {
  const auto& c = cols_;
  const std::size_t o = c.offset[i];
  return {c.k_index.data() + o, c.kt_index.data() + o, c.c.data() + o,        c.m.data() + o,
          c.b.data() + o,       c.z_mean_m.data() + o, c.z_var_m2.data() + o, c.count[i],
          c.u_ref[i],           c.site[i]};
}

std::size_t TableStore::bytes() const {
  const auto& c = cols_;
  return (c.k_index.capacity() + c.kt_index.capacity()) * sizeof(std::int32_t) +
         (c.c.capacity() + c.m.capacity() + c.b.capacity() + c.z_mean_m.capacity() + c.z_var_m2.capacity()) *
             sizeof(float) +
         c.offset.capacity() * sizeof(std::uint64_t) + (c.count.capacity() + c.site.capacity()) * sizeof(std::uint32_t) +
         c.u_ref.capacity() * sizeof(double);
}

}  // namespace ssrfleet::model
