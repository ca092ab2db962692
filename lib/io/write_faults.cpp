#include "io/write_faults.hpp"

#include <atomic>

#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
std::atomic<int> g_countdown{0};  // 0: disarmed
std::atomic<int> g_seen{0};
}  // namespace

void arm_write_fault(int operations) {
  g_seen = 0;
  g_countdown = operations > 0 ? operations : 0;
}

void disarm_write_fault() { g_countdown = 0; }

int write_operations_seen() { return g_seen.load(); }

void check_write_fault(const std::string& path) {
  ++g_seen;
  if (g_countdown.load() == 0) return;
  if (--g_countdown == 0) throw IoError("writing '" + path + "' failed: No space left on device (injected)");
}

}  // namespace ssrfleet::io
