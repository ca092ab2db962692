// What needs simulation (the SSR at positions the user types, the damage profile, a vehicle class
// or a site alone) is computed here, off the request threads: one worker thread at the lowest CPU
// priority (nice 19), so that on a shared machine the stream, at normal priority, always comes
// first; a bounded queue of distinct jobs, each key at most once in it; results cached by key with
// the checkpoint they were computed at. A request gets the newest result at once (marked stale if
// the stream has moved on), and a job for the new checkpoint is queued only when none for that key
// is already waiting, so a page polled by any number of clients costs at most one computation per
// key per checkpoint, and none at all while nobody asks.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

namespace ssrfleet::serve {

struct ComputeResult {
  std::uint64_t seq = 0;    // the checkpoint computed at
  std::int64_t trucks = 0;  // its trucks
  int status = 200;         // 200, or the HTTP status of the error in body
  nlohmann::json body;
  double seconds = 0.0;  // how long the computation took
};

class Computations {
 public:
  // A job runs on the worker; `have` is the result already cached for its key (or null), so a job
  // whose input has not changed since returns null and leaves it in place.
  using Job =
      std::function<std::shared_ptr<const ComputeResult>(const std::shared_ptr<const ComputeResult>& have)>;

  Computations(std::size_t queue_limit, std::size_t cache_limit);
  ~Computations();
  Computations(const Computations&) = delete;
  Computations& operator=(const Computations&) = delete;

  struct Lookup {
    std::shared_ptr<const ComputeResult> result;  // the newest for the key, null if none yet
    bool pending = false;                         // a job for the key is queued or running
    bool refused = false;                         // the queue was full: nothing queued
  };
  // The newest result for `key`; queues `job` unless a result at checkpoint >= wanted_seq exists or
  // a job for the key is pending.
  Lookup request(const std::string& key, std::uint64_t wanted_seq, Job job);

  std::size_t queued() const;
  std::uint64_t computed() const;  // jobs that produced a result, since start

 private:
  void run();

  const std::size_t queue_limit_, cache_limit_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::pair<std::string, Job>> queue_;
  std::string running_;  // the key the worker is on ("" when idle)
  std::map<std::string, std::pair<std::uint64_t, std::shared_ptr<const ComputeResult>>>
      cache_;  // key -> (use, result)
  std::uint64_t use_clock_ = 0;
  std::uint64_t computed_ = 0;
  bool stop_ = false;
  std::thread worker_;
};

}  // namespace ssrfleet::serve
