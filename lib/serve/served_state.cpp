#include "serve/served_state.hpp"

#include <exception>

namespace ssrfleet::serve {

ServedState::ServedState(StateConfig config)
    : config_(std::move(config)),
      reader_(config_.dir + "/history.sqlite"),
      rejects_(config_.dir + "/rejects.csv") {}

void ServedState::refresh() {
  LockState lock = lock_state(config_.dir);
  std::shared_ptr<const Snapshot> fresh;
  std::string error;
  try {
    const auto seq = reader_.last_seq();
    std::uint64_t have = 0;
    {
      const std::lock_guard<std::mutex> guard(mutex_);
      if (snapshot_) have = snapshot_->report.seq;
    }
    if (seq && *seq != have) {
      if (auto snap = reader_.snapshot()) fresh = std::make_shared<const Snapshot>(std::move(*snap));
    }
    rejects_.refresh();
  } catch (const std::exception& e) {
    error = e.what();
  }
  const std::lock_guard<std::mutex> guard(mutex_);
  lock_ = lock;
  if (fresh) snapshot_ = std::move(fresh);
  error_ = error;
}

ServedState::View ServedState::view() const {
  const std::lock_guard<std::mutex> guard(mutex_);
  return {snapshot_, lock_, error_};
}

std::shared_ptr<const std::string> ServedState::cached_answer(const std::string& key, std::uint64_t seq) const {
  const std::lock_guard<std::mutex> guard(mutex_);
  const auto it = answers_.find(key);
  return it != answers_.end() && it->second.first == seq ? it->second.second : nullptr;
}

void ServedState::store_answer(const std::string& key, std::uint64_t seq, std::shared_ptr<const std::string> body) {
  const std::lock_guard<std::mutex> guard(mutex_);
  for (auto it = answers_.begin(); it != answers_.end();) {
    it = it->second.first < seq ? answers_.erase(it) : std::next(it);
  }
  if (answers_.size() >= 16) return;  // 16 different questions of one checkpoint: the rest are not kept
  answers_[key] = {seq, std::move(body)};
}

}  // namespace ssrfleet::serve
