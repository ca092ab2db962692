// A per-client request budget: a token bucket per client address, refilled at `per_second` up to
// `burst`. A request that finds the bucket empty gets 429 and the seconds until a token is there.
// Buckets of addresses idle for a minute are dropped, and at most kMaxClients are kept (beyond,
// the idlest go), so a scan from many addresses cannot grow the server's memory.
#pragma once

#include <cstddef>
#include <mutex>
#include <string>
#include <unordered_map>

namespace ssrfleet::serve {

class RateLimiter {
 public:
  static constexpr std::size_t kMaxClients = 4096;
  // per_second <= 0: no limit.
  RateLimiter(double per_second, double burst) : per_second_(per_second), burst_(burst) {}
  // 0 if the request may go ahead (a token is taken), else the seconds to wait.
  double take(const std::string& client, double now_s);

 private:
  struct Bucket {
    double tokens = 0.0;
    double updated_s = 0.0;
  };
  double per_second_, burst_;
  std::mutex mutex_;
  std::unordered_map<std::string, Bucket> buckets_;
  double last_sweep_s_ = 0.0;
};

}  // namespace ssrfleet::serve
