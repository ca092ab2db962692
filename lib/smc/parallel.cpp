#include "smc/parallel.hpp"

#include <algorithm>
#include <exception>
#include <stdexcept>
#include <thread>
#include <vector>

#include "util/check.hpp"

namespace ssrfleet::smc {

ParallelFor::ParallelFor(int threads) : threads_(threads) {
  check_greater_or_equal("ParallelFor", "threads", threads, 1);
}

void ParallelFor::operator()(Eigen::Index n,
                             const std::function<void(Eigen::Index, Eigen::Index)>& body) const {
  if (n <= 0) return;
  const Eigen::Index chunks = std::min<Eigen::Index>(threads_, n);
  if (chunks == 1) {
    body(0, n);
    return;
  }
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(chunks));
  auto run_chunk = [&](Eigen::Index c) {
    const Eigen::Index begin = n * c / chunks;
    const Eigen::Index end = n * (c + 1) / chunks;
    try {
      body(begin, end);
    } catch (...) {
      errors[static_cast<std::size_t>(c)] = std::current_exception();
    }
  };
  {
    std::vector<std::jthread> workers;
    workers.reserve(static_cast<std::size_t>(chunks - 1));
    for (Eigen::Index c = 1; c < chunks; ++c) workers.emplace_back(run_chunk, c);
    run_chunk(0);
  }  // jthreads join here
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace ssrfleet::smc
