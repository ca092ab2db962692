// The query string of an API request, parsed without trusting a byte of it: this is the one part of
// the server that sees raw client input, so it is pure (no I/O, no state) and fuzzed
// (fuzz/serve_query_fuzzer.cpp). Every refusal is a QueryError naming the parameter, which the
// routes turn into a 400 with that name in the JSON body.
//
// Limits (docs/serve.md): a query of at most kMaxQueryBytes bytes, at most kMaxParameters
// parameters, each named by 1 to 32 of [a-z_], each at most once, values percent-decoded to at
// most kMaxValueBytes bytes with no control character; positions at most kMaxPositions, finite and strictly
// increasing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ssrfleet::serve {

inline constexpr std::size_t kMaxQueryBytes = 2048;
inline constexpr std::size_t kMaxParameters = 16;
inline constexpr std::size_t kMaxValueBytes = 1024;
inline constexpr std::size_t kMaxPositions = 1000;

// A refused query: `parameter` is the name the client should fix ("query" for the string as a whole).
class QueryError : public std::runtime_error {
 public:
  QueryError(std::string parameter, const std::string& reason)
      : std::runtime_error(reason), parameter_(std::move(parameter)) {}
  const std::string& parameter() const { return parameter_; }

 private:
  std::string parameter_;
};

class Query {
 public:
  // Parses "a=1&b=x%2Cy" (without the '?'); "" is no parameters. "a" alone is a = "".
  static Query parse(std::string_view raw);

  // QueryError naming the first parameter that is not in `allowed`.
  void only(std::initializer_list<std::string_view> allowed) const;
  // The value, none if absent.
  std::optional<std::string> get(std::string_view name) const;
  // An integer in [min, max], `fallback` if absent; QueryError naming it otherwise.
  std::int64_t integer(std::string_view name, std::int64_t fallback, std::int64_t min,
                       std::int64_t max) const;
  // A label: 1 to 64 of [A-Za-z0-9_.-] (a state, class or site name), none if absent or empty.
  std::optional<std::string> label(std::string_view name) const;
  // Positions in metres: "76,77.5,80" or "FIRST:STEP:LAST" (inclusive, computed as FIRST + i STEP,
  // as ssrfleet predict --positions does, so both give the same positions); empty if absent.
  std::vector<double> positions(std::string_view name) const;

  const std::vector<std::pair<std::string, std::string>>& parameters() const { return parameters_; }

 private:
  std::vector<std::pair<std::string, std::string>> parameters_;
};

// The positions grammar alone (what Query::positions applies), for a value already decoded.
std::vector<double> parse_positions_value(const std::string& parameter, std::string_view text);

}  // namespace ssrfleet::serve
