// A parallel loop as a value the lower layers can accept without knowing the thread pool:
// parallel(n, body) calls body(begin, end) on chunks covering [0, n). Bodies must write only to
// their own range, so results do not depend on the chunking (smc::ParallelFor is one).
#pragma once

#include <functional>

#include <Eigen/Core>

namespace ssrfleet::util {

using RangeBody = std::function<void(Eigen::Index begin, Eigen::Index end)>;
using ParallelRange = std::function<void(Eigen::Index n, const RangeBody& body)>;

// Runs the body on the whole range in the calling thread.
inline void serial_range(Eigen::Index n, const RangeBody& body) {
  if (n > 0) body(0, n);
}

}  // namespace ssrfleet::util
