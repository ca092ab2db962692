// util::Ranks over MPI_COMM_WORLD (docs/sites.md): the one file of the project that
// includes mpi.h, built only with -DSSRFLEET_MPI=ON into ssrfleet-mpi.
#pragma once

#include <cstdint>

#include "util/ranks.hpp"

namespace ssrfleet::mpi {

class MpiRanks final : public util::Ranks {
 public:
  // After MPI_Init; registers the exact sums' datatype and reduction, freed by the destructor
  // (before MPI_Finalize).
  MpiRanks();
  ~MpiRanks() override;
  MpiRanks(const MpiRanks&) = delete;
  MpiRanks& operator=(const MpiRanks&) = delete;

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void sum(util::ExactSum* sums, std::size_t count) const override;
  void broadcast(void* data, std::size_t bytes, int root) const override;
  std::vector<std::string> gather(const std::string& mine, int root) const override;
  void share_slices(double* values, std::size_t count) const override;
  Traffic traffic() const override { return traffic_; }

 private:
  int rank_ = 0, size_ = 1;
  // MPI handles, kept as their integer-sized opaque values (Open MPI's are pointers).
  struct Handles;
  Handles* handles_;
  mutable Traffic traffic_;
};

}  // namespace ssrfleet::mpi
