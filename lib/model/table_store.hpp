// Every absorbed truck's table (truck_table.hpp) in contiguous arrays, one per field, so the sum
// Σ_i ℓ_i(θ) that every θ move evaluates streams through memory once instead of chasing a heap
// allocation per truck. Append-only; a rebuild fills a new store.
#pragma once

#include <cstdint>
#include <vector>

#include "model/truck_table.hpp"

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
  std::size_t nodes = 0;
  double u_ref = 0.0;
  // Which of the fit's sites logged the truck (FleetMarginal's per-site constants; 0 for one site).
  std::uint32_t site = 0;
};

TableView view_of(const TruckTable& table);

class TableStore {
 public:
  void append(const TruckTable& table, std::uint32_t site = 0);
  std::size_t trucks() const { return cols_.offset.size(); }
  TableView view(std::size_t truck) const;
  std::size_t nodes() const { return cols_.c.size(); }
  std::size_t bytes() const;
  void reserve(std::size_t trucks, std::size_t nodes);

  // Raw fields, for checkpoints.
  struct Columns {
    std::vector<std::int32_t> k_index, kt_index;
    std::vector<float> c, m, b, z_mean_m, z_var_m2;
    std::vector<std::uint64_t> offset;
    std::vector<std::uint32_t> count;
    std::vector<double> u_ref;
    std::vector<std::uint32_t> site;
  };
  Columns& columns() { return cols_; }
  const Columns& columns() const { return cols_; }

 private:
  Columns cols_;
};

}  // namespace ssrfleet::model
