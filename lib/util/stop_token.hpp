// Stopping a long call from another thread (an interactive user's Ctrl-C in the Python module).
//
// A StopToken is a flag another thread trips; the library's long loops (the tempered SMC's steps
// and move sweeps, the batch MCMC's sweeps and its per-truck starting fits, diagnose's candidates,
// predict's and damage's classes) call throw_if_stopped(), which throws Stopped once the token of
// the current call is tripped. The stream's record loop checks stop_requested() between records
// and ends as on its stop flag, its state saved; a tripped current token may still stop the
// record in hand inside its SMC stage (the state on disk is then the last record's), so a caller
// that wants the stream object to stay usable passes StopToken::flag() as the stream's stop flag
// and installs no current token (the Python module's Stream does). Between two checks lies one
// step, sweep, truck or class: well under a second at the sizes the commands run, so a call ends
// within a second of the trip.
//
// How a call receives its token: a thread-local "current token", installed for a scope by
// StopScope in the thread that drives the call. Not a field in the option structs, because a fit
// reaches its loops through many layers (the commands' fit functions, the cores, the sampler) whose
// options would all have to carry it; the thread-local reaches every loop of the call without
// touching them. Only driver threads check: the workers of a parallel loop never have a token
// (theirs is null), so throw_if_stopped inside a parallel body is a no-op; a chain that runs on a
// thread of its own (the batch MCMC's chains) is given its driver's token by StopScope there, and
// the one parallel loop long enough to need a check takes the driver's token along (StopCheck).
// With no token installed (the command line), a check is a call, a thread-local load and a
// compare: nothing beside a step or a sweep.
//
// Stopped is its own type (not a DataError or a UsageError, and not a std::runtime_error, so no
// handler written for those swallows it): the caller that tripped the token expects it and nobody
// else should catch it. A call that throws it leaves its in-memory results unusable; files it
// writes atomically (the stream's state) are as the last completed write left them.
#pragma once

#include <atomic>
#include <exception>

namespace ssrfleet::util {

class Stopped : public std::exception {
 public:
  const char* what() const noexcept override { return "stopped on request"; }
};

class StopToken {
 public:
  void request_stop() noexcept { stopped_.store(true, std::memory_order_relaxed); }
  bool stop_requested() const noexcept { return stopped_.load(std::memory_order_relaxed); }
  // The flag itself, for a loop that takes an atomic stop flag and ends cleanly on it
  // (stream::WimStream::run ends after the record in hand, its state saved).
  const std::atomic<bool>& flag() const noexcept { return stopped_; }

 private:
  std::atomic<bool> stopped_{false};
};

// The token the calling thread's work honours (nullptr: none).
const StopToken* current_stop_token() noexcept;

// Installs `token` as the calling thread's current token for the scope's life (nullptr: none),
// then puts back the one before.
class StopScope {
 public:
  explicit StopScope(const StopToken* token) noexcept;
  ~StopScope();
  StopScope(const StopScope&) = delete;
  StopScope& operator=(const StopScope&) = delete;

 private:
  const StopToken* previous_;
};

// The calling thread's token, taken along into a parallel loop's body, whose workers have none of
// their own: for a loop that alone runs long (the batch MCMC's per-truck starting fits), so it
// stops within a second too. Construct it in the driver thread before the loop.
class StopCheck {
 public:
  StopCheck() noexcept : token_(current_stop_token()) {}
  void operator()() const {
    if (token_ != nullptr && token_->stop_requested()) throw Stopped();
  }

 private:
  const StopToken* token_;
};

// True when the calling thread's token is tripped (false without a token).
bool stop_requested() noexcept;
// Throws Stopped when the calling thread's token is tripped.
void throw_if_stopped();

}  // namespace ssrfleet::util
