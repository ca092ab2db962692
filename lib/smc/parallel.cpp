#include "smc/parallel.hpp"

#include <algorithm>
#include <exception>
#include <stdexcept>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "util/check.hpp"

namespace ssrfleet::smc {

namespace {
// True on a thread that is running a chunk: a nested loop there runs serially instead of
// waiting on the pool it is part of.
thread_local bool inside_chunk = false;
}  // namespace

// Workers 1..k wait for a generation number to change, run their chunk of the current job and
// count down; the caller runs chunk 0 and waits for the count to reach zero.
class WorkerPool {
 public:
  explicit WorkerPool(int workers) {
    threads_.reserve(static_cast<std::size_t>(workers));
    for (int w = 1; w <= workers; ++w) threads_.emplace_back([this, w] { work(w); });
  }
  ~WorkerPool() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    start_.notify_all();
    for (auto& t : threads_) t.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(const std::function<void(Eigen::Index)>& chunk, Eigen::Index chunks) {
    std::lock_guard one_job_at_a_time(run_mutex_);
    {
      std::lock_guard lock(mutex_);
      job_ = &chunk;
      chunks_ = chunks;
      pending_ = static_cast<int>(threads_.size());
      ++generation_;
    }
    start_.notify_all();
    inside_chunk = true;
    chunk(0);
    inside_chunk = false;
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
  }

 private:
  void work(int w) {
    std::uint64_t seen = 0;
    for (;;) {
      std::unique_lock lock(mutex_);
      start_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      const auto* job = job_;
      const Eigen::Index chunks = chunks_;
      lock.unlock();
      if (w < chunks) {
        inside_chunk = true;
        (*job)(w);
        inside_chunk = false;
      }
      lock.lock();
      if (--pending_ == 0) done_.notify_one();
    }
  }

  std::vector<std::thread> threads_;
  std::mutex run_mutex_, mutex_;
  std::condition_variable start_, done_;
  const std::function<void(Eigen::Index)>* job_ = nullptr;
  Eigen::Index chunks_ = 0;
  std::uint64_t generation_ = 0;
  int pending_ = 0;
  bool stop_ = false;
};

ParallelFor::ParallelFor(int threads) : threads_(threads) {
  check_greater_or_equal("ParallelFor", "threads", threads, 1);
  if (threads_ > 1) pool_ = std::make_shared<WorkerPool>(threads_ - 1);
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
  const std::function<void(Eigen::Index)> run_chunk = [&](Eigen::Index c) {
    const Eigen::Index begin = n * c / chunks;
    const Eigen::Index end = n * (c + 1) / chunks;
    try {
      body(begin, end);
    } catch (...) {
      errors[static_cast<std::size_t>(c)] = std::current_exception();
    }
  };
  if (inside_chunk) {
    for (Eigen::Index c = 0; c < chunks; ++c) run_chunk(c);  // nested: same chunks, serially
  } else {
    pool_->run(run_chunk, chunks);
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace ssrfleet::smc
