#include "serve/computations.hpp"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <exception>

#include "util/free_memory.hpp"

namespace ssrfleet::serve {

Computations::Computations(std::size_t queue_limit, std::size_t cache_limit)
    : queue_limit_(queue_limit), cache_limit_(cache_limit), worker_([this] { run(); }) {}

Computations::~Computations() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  worker_.join();
}

Computations::Lookup Computations::request(const std::string& key, std::uint64_t wanted_seq, Job job) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Lookup out;
  if (auto it = cache_.find(key); it != cache_.end()) {
    it->second.first = ++use_clock_;
    out.result = it->second.second;
    if (out.result->seq >= wanted_seq) return out;
  }
  bool pending = running_ == key;
  for (const auto& queued : queue_) pending = pending || queued.first == key;
  if (pending) {
    out.pending = true;
    return out;
  }
  if (queue_.size() >= queue_limit_) {
    out.refused = true;
    return out;
  }
  queue_.emplace_back(key, std::move(job));
  out.pending = true;
  wake_.notify_one();
  return out;
}

std::size_t Computations::queued() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

std::uint64_t Computations::computed() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return computed_;
}

void Computations::run() {
  // This thread alone: Linux applies setpriority to one thread given its id.
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 19);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    auto [key, job] = std::move(queue_.front());
    queue_.pop_front();
    running_ = key;
    std::shared_ptr<const ComputeResult> have;
    if (auto it = cache_.find(key); it != cache_.end()) have = it->second.second;
    lock.unlock();
    std::shared_ptr<const ComputeResult> result;
    const auto start = std::chrono::steady_clock::now();
    try {
      result = job(have);
    } catch (const std::exception& e) {
      auto failed = std::make_shared<ComputeResult>();
      failed->seq = have ? have->seq : 0;
      failed->status = 503;
      failed->body = {{"error", e.what()}, {"parameter", nullptr}};
      result = failed;
    }
    if (result) {
      auto timed = std::make_shared<ComputeResult>(*result);
      timed->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      result = timed;
    }
    // A computation's transient buffers (the posterior file's text and tree, the simulated passes)
    // are megabytes: handed back at once, so the server's resident memory does not creep.
    util::return_free_memory();
    lock.lock();
    running_.clear();
    if (result) {
      ++computed_;
      cache_[key] = {++use_clock_, result};
      while (cache_.size() > cache_limit_) {  // the least recently used goes
        auto oldest = cache_.begin();
        for (auto it = cache_.begin(); it != cache_.end(); ++it) {
          if (it->second.first < oldest->second.first) oldest = it;
        }
        cache_.erase(oldest);
      }
    }
  }
}

}  // namespace ssrfleet::serve
