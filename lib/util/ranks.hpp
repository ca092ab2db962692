// The processes one fit runs on (docs/sites.md), as the fleet layer sees them: a rank
// number, a count, and the three collective operations the marginal core needs. One process is
// SingleRank (every operation a no-op); the MPI build's ssrfleet-mpi supplies another
// (mpi/mpi_ranks.*), so nothing below bin/ includes mpi.h.
//
// The contract: every rank runs the same SMC with the same seed, so particles, weights and every
// decision are replicated; only the trucks are split. A truck belongs to rank truck % size()
// (round-robin, so every rank's share grows alike and the newest truck moves from rank to rank).
// Each rank keeps the tables of its own trucks and sums their ℓ_i(θ) for every particle; sum()
// adds the ranks' partial sums, which are exact (util/exact_sum.hpp), so the total has the same
// bits for any number of ranks and any order of arrival.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "util/exact_sum.hpp"

namespace ssrfleet::util {

class Ranks {
 public:
  virtual ~Ranks() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;

  // Collective (every rank calls it, in the same order): element-wise sum over the ranks of
  // `count` exact sums, in place; every rank gets the totals.
  virtual void sum(ExactSum* sums, std::size_t count) const = 0;
  // Collective: `bytes` bytes at `data` copied from rank `root` to every rank.
  virtual void broadcast(void* data, std::size_t bytes, int root) const = 0;
  // Collective: every rank's `mine`, in rank order, at rank `root` (empty elsewhere).
  virtual std::vector<std::string> gather(const std::string& mine, int root) const = 0;
  // Collective: `values` holds `count` numbers of which this rank has filled its own slice
  // (slice(count)); afterwards every rank holds every rank's slice.
  virtual void share_slices(double* values, std::size_t count) const = 0;

  // What this rank has sent so far (for the scaling benchmark): collective calls and payload bytes.
  struct Traffic {
    std::uint64_t calls = 0;
    std::uint64_t bytes = 0;
  };
  virtual Traffic traffic() const = 0;

  // Which rank keeps item i (a truck, in arrival order).
  int owner(std::uint64_t i) const { return static_cast<int>(i % static_cast<std::uint64_t>(size())); }
  bool owns(std::uint64_t i) const { return owner(i) == rank(); }
  // This rank's share [first, second) of `count` items cut into contiguous slices in rank order
  // (the particles whose newest-truck likelihood this rank computes).
  std::pair<std::size_t, std::size_t> slice(std::size_t count) const { return slice_of(rank(), count); }
  std::pair<std::size_t, std::size_t> slice_of(int r, std::size_t count) const {
    const auto s = static_cast<std::size_t>(size()), k = static_cast<std::size_t>(r);
    return {count * k / s, count * (k + 1) / s};
  }
};

class SingleRank final : public Ranks {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void sum(ExactSum*, std::size_t) const override {}
  void broadcast(void*, std::size_t, int) const override {}
  std::vector<std::string> gather(const std::string& mine, int) const override { return {mine}; }
  void share_slices(double*, std::size_t) const override {}
  Traffic traffic() const override { return {}; }
};

// The one process's ranks (a shared instance: SingleRank has no state).
const Ranks& single_rank();

}  // namespace ssrfleet::util
