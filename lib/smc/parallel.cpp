#include "smc/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
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
//
// Both waits spin for a short while before they sleep on a condition variable. A fleet replay
// makes ~25 000 parallel calls, most of them a few hundred microseconds long with ~30 us of serial
// work between them; waking a sleeping thread through the kernel costs tens of microseconds on a
// virtual machine, and it was measured to idle a second core for ~10 % of a 2-thread replay. The
// spin is bounded (kSpin), so a pool that waits long between jobs still sleeps, and it yields the
// core on every round, so more threads than cores still make progress.
class WorkerPool {
 public:
  explicit WorkerPool(int workers) {
    threads_.reserve(static_cast<std::size_t>(workers));
    for (int w = 1; w <= workers; ++w) threads_.emplace_back([this, w] { work(w); });
  }
  ~WorkerPool() {
    {
      std::lock_guard lock(mutex_);
      stop_.store(true, std::memory_order_release);
    }
    start_.notify_all();
    for (auto& t : threads_) t.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(const std::function<void(Eigen::Index)>& chunk, Eigen::Index chunks) {
    std::lock_guard one_job_at_a_time(run_mutex_);
    {
      // Under the mutex, so a worker about to sleep either sees the new generation or is woken.
      std::lock_guard lock(mutex_);
      job_ = &chunk;
      chunks_ = chunks;
      pending_.store(static_cast<int>(threads_.size()), std::memory_order_relaxed);
      generation_.fetch_add(1, std::memory_order_release);
    }
    start_.notify_all();
    inside_chunk = true;
    chunk(0);
    inside_chunk = false;
    if (spin_until([this] { return pending_.load(std::memory_order_acquire) == 0; })) return;
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_.load(std::memory_order_acquire) == 0; });
  }

 private:
  // Spins (yielding) until ready() or kSpin has passed; returns ready().
  template <class Ready>
  static bool spin_until(const Ready& ready) {
    const auto until = std::chrono::steady_clock::now() + kSpin;
    for (int round = 0;; ++round) {
      if (ready()) return true;
      if ((round & 63) == 63 && std::chrono::steady_clock::now() > until) return false;
      std::this_thread::yield();
    }
  }

  void work(int w) {
    std::uint64_t seen = 0;
    for (;;) {
      const auto fresh = [&] {
        return stop_.load(std::memory_order_acquire) || generation_.load(std::memory_order_acquire) != seen;
      };
      if (!spin_until(fresh)) {
        std::unique_lock lock(mutex_);
        start_.wait(lock, fresh);
      }
      if (stop_.load(std::memory_order_acquire)) return;
      const std::function<void(Eigen::Index)>* job = nullptr;
      Eigen::Index chunks = 0;
      {
        std::lock_guard lock(mutex_);  // job_ and chunks_ were written under it
        seen = generation_.load(std::memory_order_relaxed);
        job = job_;
        chunks = chunks_;
      }
      if (w < chunks) {
        inside_chunk = true;
        (*job)(w);
        inside_chunk = false;
      }
      if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        std::lock_guard lock(mutex_);  // pairs with the caller's predicate check before it sleeps
        done_.notify_one();
      }
    }
  }

  static constexpr std::chrono::microseconds kSpin{200};
  std::vector<std::thread> threads_;
  std::mutex run_mutex_, mutex_;
  std::condition_variable start_, done_;
  const std::function<void(Eigen::Index)>* job_ = nullptr;
  Eigen::Index chunks_ = 0;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> pending_{0};
  std::atomic<bool> stop_{false};
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
