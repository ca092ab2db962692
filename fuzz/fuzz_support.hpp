// What every harness shares: the rule that tells a clean rejection from a bug.
//
// A parser given bad bytes owes the user a clean error: one of the project's errors
// (util/errors.hpp: DataError for bad data, UsageError for a bad option or spec) or the
// std::invalid_argument of util/check.hpp. Those are caught here and the input counts as handled.
// Anything else (another exception, a sanitizer report, a hang, a huge allocation) escapes and
// libFuzzer records the input as a crash. A DataError must also name the input it is about, so
// a user can find the line it points at.
//
// SSRFLEET_FUZZ_VERBOSE=1 in the environment prints each caught error (to check a seed corpus:
// FUZZER corpus/<name>/* runs each file once).
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

#include "util/errors.hpp"

namespace ssrfleet::fuzz {

inline bool verbose() {
  static const bool on = std::getenv("SSRFLEET_FUZZ_VERBOSE") != nullptr;
  return on;
}

inline void note(const char* kind, const std::exception& e) {
  if (verbose()) std::fprintf(stderr, "clean %s: %s\n", kind, e.what());
}

// Runs body(); a clean rejection returns normally, anything else propagates (libFuzzer: crash).
template <class Body>
void expect_clean(std::string_view source, Body&& body) {
  try {
    body();
    if (verbose()) std::fprintf(stderr, "accepted\n");
  } catch (const DataError& e) {
    if (!source.empty() && std::string_view(e.what()).find(source) == std::string_view::npos) {
      std::fprintf(stderr, "DataError does not name its input '%.*s': %s\n", static_cast<int>(source.size()),
                   source.data(), e.what());
      std::abort();
    }
    note("DataError", e);
  } catch (const UsageError& e) {
    note("UsageError", e);
  } catch (const std::invalid_argument& e) {
    note("invalid_argument", e);
  }
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace ssrfleet::fuzz
