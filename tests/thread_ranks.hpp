// Threads standing in for MPI ranks (util::Ranks), so the default build's tests check what a fit
// split over ranks does (fleet_ranks_test.cpp) without an MPI runtime: the same contract, every
// rank calls every collective in the same order, and each collective is a rendezvous of all.
#pragma once

#include <barrier>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "util/ranks.hpp"

namespace ssrfleet::testing {

class ThreadRanks final : public util::Ranks {
 public:
  struct Shared {
    explicit Shared(int n)
        : size(n), sync(n), sums(static_cast<std::size_t>(n)), texts(static_cast<std::size_t>(n)),
          slices(static_cast<std::size_t>(n)) {}
    int size;
    std::barrier<> sync;
    std::vector<std::vector<util::ExactSum>> sums;
    std::vector<const std::string*> texts;
    std::vector<const double*> slices;
    const void* broadcast = nullptr;
  };
  ThreadRanks(Shared& shared, int rank) : shared_(shared), rank_(rank) {}

  int rank() const override { return rank_; }
  int size() const override { return shared_.size; }
  void sum(util::ExactSum* sums, std::size_t count) const override {
    shared_.sums[static_cast<std::size_t>(rank_)].assign(sums, sums + count);
    shared_.sync.arrive_and_wait();
    // Added in the reverse of rank order: exact sums do not care.
    for (std::size_t i = 0; i < count; ++i) {
      util::ExactSum total;
      for (int r = size() - 1; r >= 0; --r) total.add(shared_.sums[static_cast<std::size_t>(r)][i]);
      sums[i] = total;
    }
    shared_.sync.arrive_and_wait();
    ++traffic_.calls;
  }
  void broadcast(void* data, std::size_t bytes, int root) const override {
    if (rank_ == root) shared_.broadcast = data;
    shared_.sync.arrive_and_wait();
    if (rank_ != root) std::memcpy(data, shared_.broadcast, bytes);
    shared_.sync.arrive_and_wait();
    ++traffic_.calls;
  }
  std::vector<std::string> gather(const std::string& mine, int root) const override {
    shared_.texts[static_cast<std::size_t>(rank_)] = &mine;
    shared_.sync.arrive_and_wait();
    std::vector<std::string> all;
    if (rank_ == root)
      for (const std::string* t : shared_.texts) all.push_back(*t);
    shared_.sync.arrive_and_wait();
    ++traffic_.calls;
    return all;
  }
  void share_slices(double* values, std::size_t count) const override {
    shared_.slices[static_cast<std::size_t>(rank_)] = values;
    shared_.sync.arrive_and_wait();
    for (int r = 0; r < size(); ++r) {
      if (r == rank_) continue;
      const auto [first, last] = slice_of(r, count);
      std::memcpy(values + first, shared_.slices[static_cast<std::size_t>(r)] + first, (last - first) * sizeof(double));
    }
    shared_.sync.arrive_and_wait();
    ++traffic_.calls;
  }
  Traffic traffic() const override { return traffic_; }

 private:
  Shared& shared_;
  int rank_;
  mutable Traffic traffic_;
};

// Runs body(ranks) on `n` threads, one rank each, and waits for all (an exception on any rank is
// rethrown here, the lowest rank's first: a test must not hang on a rank that failed).
inline void run_on_ranks(int n, const std::function<void(const util::Ranks&)>& body) {
  ThreadRanks::Shared shared(n);
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(n));
  {
    std::vector<std::jthread> threads;
    for (int r = 0; r < n; ++r) {
      threads.emplace_back([&, r] {
        try {
          ThreadRanks ranks(shared, r);
          body(ranks);
        } catch (...) {
          errors[static_cast<std::size_t>(r)] = std::current_exception();
          shared.sync.arrive_and_drop();  // the others' collectives stop waiting for this rank
        }
      });
    }
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace ssrfleet::testing
