// The query strings of ssrfleet serve's API (serve/query.hpp): the only bytes of a request that
// reach ssrfleet's own parsing. Every refusal must be a QueryError naming a parameter of at most
// 32 printable bytes (it goes back to the client in JSON); an accepted query must keep its limits
// (parameters, value sizes, positions finite, strictly increasing and at most kMaxPositions).
#include <cmath>
#include <cstdlib>
#include <string>

#include "fuzz_support.hpp"
#include "serve/query.hpp"

using namespace ssrfleet;

namespace {
void check_parameter(const serve::QueryError& e) {
  const std::string& p = e.parameter();
  if (p.empty() || p.size() > 32) std::abort();
  for (const char c : p) {
    if (c < 0x20 || c >= 0x7f) std::abort();
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text(data, size);
  try {
    const serve::Query q = serve::Query::parse(text);
    if (q.parameters().size() > serve::kMaxParameters) std::abort();
    for (const auto& [name, value] : q.parameters()) {
      if (value.size() > serve::kMaxValueBytes || value.find('\0') != std::string::npos) std::abort();
      try {
        q.integer(name, 0, -1000, 1000);
      } catch (const serve::QueryError& e) {
        check_parameter(e);
      }
      try {
        q.label(name);
      } catch (const serve::QueryError& e) {
        check_parameter(e);
      }
      try {
        const auto p = q.positions(name);
        if (p.size() > serve::kMaxPositions) std::abort();
        for (std::size_t i = 0; i < p.size(); ++i) {
          if (!std::isfinite(p[i]) || (i > 0 && !(p[i] > p[i - 1]))) std::abort();
        }
      } catch (const serve::QueryError& e) {
        check_parameter(e);
      }
    }
    try {
      q.only({"state", "positions", "class", "site"});
    } catch (const serve::QueryError& e) {
      check_parameter(e);
    }
  } catch (const serve::QueryError& e) {
    check_parameter(e);
  }
  return 0;
}
