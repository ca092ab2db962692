// Every absorbed truck's table (truck_table.hpp) in one append-only arena, truck after truck, so
// the sum Σ_i ℓ_i(θ) that every θ move evaluates streams through memory once instead of chasing a
// heap allocation per truck. A truck's record is its nodes' nine fields, each contiguous
// (k_index, kt_index, c, m, b, z_mean_m, z_var_m2, z_mean_slope_m, z_var_slope_m2: 36 bytes a node,
// every field 4-byte aligned).
//
// The arena and the per-truck index live in the process's memory, or, given a directory, in
// unnamed files there that the kernel pages (util/spill_vector.hpp): a stream's tables grow by
// about 6 kB a truck, and in files they leave the process's private memory flat
// (docs/streaming.md). Append-only; a rebuild fills a new store.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "model/truck_table.hpp"
#include "util/spill_vector.hpp"

namespace ssrfleet::model {

// One truck's nodes, wherever they are stored.
struct TableView {
  const std::int32_t* k_index = nullptr;
  const std::int32_t* kt_index = nullptr;
  const float* c = nullptr;
  const float* m = nullptr;
  const float* b = nullptr;
  const float* z_mean_m = nullptr;
  const float* z_var_m2 = nullptr;
  const float* z_mean_slope_m = nullptr;
  const float* z_var_slope_m2 = nullptr;
  std::size_t nodes = 0;
  double u_ref = 0.0;
  // Which of the fit's sites logged the truck (FleetMarginal's per-site constants; 0 for one site).
  std::uint32_t site = 0;
};

TableView view_of(const TruckTable& table);

class TableStore {
 public:
  static constexpr std::size_t kBytesPerNode = 2 * sizeof(std::int32_t) + 7 * sizeof(float);

  // In memory.
  TableStore() = default;
  // In unnamed files in `spill_directory` ("": in memory). IoError if a file cannot be made.
  explicit TableStore(const std::string& spill_directory);

  // Appends a truck's table (IoError from a full disk: the store is then as it was).
  void append(const TruckTable& table, std::uint32_t site = 0);
  std::size_t trucks() const { return index_.size(); }
  // Valid until the next append.
  TableView view(std::size_t truck) const;
  std::size_t nodes() const { return index_.empty() ? 0 : index_.back().offset + index_.back().count; }
  // The first node of a truck (FleetMarginal blocks its sums by it).
  std::uint64_t node_offset(std::size_t truck) const { return index_[truck].offset; }
  // Bytes held in the process's memory (0 when spilled).
  std::size_t bytes() const { return arena_.memory_bytes() + index_.memory_bytes(); }
  // Bytes in the spill files (0 in memory).
  std::size_t spilled_bytes() const {
    return spilled() ? arena_.size() + index_.size() * sizeof(Entry) : 0;
  }
  bool spilled() const { return arena_.spilled(); }
  // The directory a spilled store's files are in ("" in memory): a rebuild's new store goes there too.
  const std::string& spill_directory() const { return arena_.directory(); }

 private:
  struct Entry {
    std::uint64_t offset = 0;  // first node
    double u_ref = 0.0;
    std::uint32_t count = 0;   // nodes
    std::uint32_t site = 0;
  };
  util::SpillVector<std::byte> arena_;  // the records, truck after truck
  util::SpillVector<Entry> index_;      // one entry a truck
  std::vector<std::byte> record_;      // scratch: the record being appended
};

}  // namespace ssrfleet::model
