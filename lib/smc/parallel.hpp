// Fixed-chunk parallel loop over particles. [0, n) is cut into at most threads() contiguous
// chunks, each run on its own std::jthread (the calling thread runs the first). Work per particle
// must depend only on the particle (its counter-based random stream, its state), never on the
// chunk, so results are bit-identical whatever the thread count; reductions over particles are
// done by the caller, serially, after the loop.
#pragma once

#include <functional>
#include <memory>

#include <Eigen/Core>

namespace ssrfleet::smc {

class ParallelFor {
 public:
  // threads >= 1, else std::invalid_argument.
  explicit ParallelFor(int threads = 1);

  int threads() const { return threads_; }

  // Calls body(begin, end) on chunks covering [0, n). body may only write to its own range.
  // If chunks throw, the exception of the first chunk (in index order) is rethrown here after
  // all chunks finished, so the error a caller sees does not depend on thread timing either.
  void operator()(Eigen::Index n, const std::function<void(Eigen::Index begin, Eigen::Index end)>& body) const;

 private:
  int threads_;
  // threads_ - 1 workers started once and reused by every call: a loop per MCMC sweep would
  // otherwise start and join threads thousands of times per truck. Copies share the pool.
  std::shared_ptr<class WorkerPool> pool_;
};

}  // namespace ssrfleet::smc
