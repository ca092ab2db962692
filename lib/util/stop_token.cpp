#include "util/stop_token.hpp"

namespace ssrfleet::util {

namespace {
thread_local const StopToken* t_current = nullptr;
}  // namespace

const StopToken* current_stop_token() noexcept { return t_current; }

StopScope::StopScope(const StopToken* token) noexcept : previous_(t_current) { t_current = token; }
StopScope::~StopScope() { t_current = previous_; }

bool stop_requested() noexcept { return t_current != nullptr && t_current->stop_requested(); }

void throw_if_stopped() {
  if (t_current != nullptr && t_current->stop_requested()) throw Stopped();
}

}  // namespace ssrfleet::util
