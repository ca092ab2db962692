#include "serve/rate_limit.hpp"

#include <algorithm>

namespace ssrfleet::serve {

double RateLimiter::take(const std::string& client, double now_s) {
  if (per_second_ <= 0.0) return 0.0;
  const std::lock_guard<std::mutex> lock(mutex_);
  if (now_s - last_sweep_s_ > 10.0 || buckets_.size() >= kMaxClients) {
    for (auto it = buckets_.begin(); it != buckets_.end();) {
      it = now_s - it->second.updated_s > 60.0 ? buckets_.erase(it) : std::next(it);
    }
    while (buckets_.size() >= kMaxClients) {
      auto idlest = std::min_element(buckets_.begin(), buckets_.end(), [](const auto& a, const auto& b) {
        return a.second.updated_s < b.second.updated_s;
      });
      buckets_.erase(idlest);
    }
    last_sweep_s_ = now_s;
  }
  auto [it, fresh] = buckets_.try_emplace(client, Bucket{burst_, now_s});
  Bucket& b = it->second;
  if (!fresh) {
    b.tokens = std::min(burst_, b.tokens + (now_s - b.updated_s) * per_second_);
    b.updated_s = now_s;
  }
  if (b.tokens >= 1.0) {
    b.tokens -= 1.0;
    return 0.0;
  }
  return (1.0 - b.tokens) / per_second_;
}

}  // namespace ssrfleet::serve
