// Long calls from Python: the work runs on a thread of its own with the GIL released, while the
// calling thread waits in slices of 100 ms and, between them, takes the GIL to let Python run its
// signal handlers (PyErr_CheckSignals). A Ctrl-C there (KeyboardInterrupt, or whatever a handler
// raises) trips the work's stop token (util/stop_token.hpp), waits for the work to end, which its
// loops make happen within a second, and raises the handler's exception; the work's own result or
// error is then dropped. Without a signal the call returns the work's result or rethrows its error
// on the calling thread, so the exception translators see it as before.
#pragma once

#include <signal.h>

#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>
#include <utility>

#include <pybind11/pybind11.h>

#include "util/stop_token.hpp"

namespace ssrfleet::python {

// How the work honours the token: installed as the worker's current token (every library loop
// checks it and throws util::Stopped), or only handed to the work (a stream passes token.flag() as
// its stop flag and ends after the record in hand, its state saved and the object usable).
enum class StopVia { kCurrentToken, kArgumentOnly };

template <typename Work>
auto run_stoppable(Work&& work, StopVia via = StopVia::kCurrentToken) {
  namespace py = pybind11;
  using Result = std::invoke_result_t<Work&, const util::StopToken&>;
  util::StopToken token;
  std::mutex mutex;
  std::condition_variable finished;
  bool done = false;
  std::exception_ptr failure;
  std::conditional_t<std::is_void_v<Result>, bool, std::optional<Result>> result{};
  PyObject *type = nullptr, *value = nullptr, *trace = nullptr;  // the signal handler's exception
  {
    py::gil_scoped_release release;
    std::thread worker([&] {
      // Asynchronous signals go to the waiting thread, whose handler runs Python's.
      sigset_t deferred;
      sigemptyset(&deferred);
      for (const int s : {SIGINT, SIGTERM, SIGHUP, SIGALRM, SIGVTALRM, SIGPROF, SIGUSR1, SIGUSR2, SIGCHLD})
        sigaddset(&deferred, s);
      pthread_sigmask(SIG_BLOCK, &deferred, nullptr);
      {
        const util::StopScope scope(via == StopVia::kCurrentToken ? &token : nullptr);
        try {
          if constexpr (std::is_void_v<Result>) {
            work(token);
            result = true;
          } else {
            result.emplace(work(token));
          }
        } catch (...) {
          failure = std::current_exception();
        }
      }
      {
        const std::lock_guard<std::mutex> lock(mutex);
        done = true;
      }
      finished.notify_one();
    });
    std::unique_lock<std::mutex> lock(mutex);
    while (!finished.wait_for(lock, std::chrono::milliseconds(100), [&] { return done; })) {
      lock.unlock();
      bool interrupted = false;
      {
        const py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
          interrupted = true;
          PyErr_Fetch(&type, &value, &trace);
        }
      }
      lock.lock();
      if (interrupted) {
        token.request_stop();
        finished.wait(lock, [&] { return done; });
        break;
      }
    }
    lock.unlock();
    worker.join();
  }
  if (type != nullptr) {
    PyErr_Restore(type, value, trace);
    throw py::error_already_set();
  }
  if (failure) std::rethrow_exception(failure);
  if constexpr (!std::is_void_v<Result>) return std::move(*result);
}

}  // namespace ssrfleet::python
