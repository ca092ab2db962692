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

}  // namespace ssrfleet::serve
