// Every crash the fuzz harnesses (fuzz/, README "Fuzzing") found, as the input that crashed, now a
// clean DataError naming the file and the field. Each case says which harness found it and what
// the crash was.
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/posterior_json.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::data_error;

namespace {
std::optional<DataError> posterior_error(const std::string& text) {
  return data_error([&] {
    std::istringstream in(text);
    io::read_posterior(in, "fuzzed.json");
  });
}
}  // namespace

TEST_CASE("a posterior file with a number past a double is a DataError, not an internal error", "[io][fuzz]") {
  // posterior_json_fuzzer, crash-743d56fc: "q975": 2e4000 made nlohmann::json throw out_of_range
  // (not parse_error), which escaped the reader (exit 70, "internal error").
  const auto e = posterior_error(R"({"K": {"mean": 5e5, "q975": 2e4000}, "format_version": 1})");
  REQUIRE(e);
  CHECK(e->file() == "fuzzed.json");
  CHECK(e->field() == "json");
  CHECK_THAT(e->what(), Catch::Contains("not valid JSON") && Catch::Contains("2e4000"));
}

TEST_CASE("a posterior file's integer fields take whole numbers in range only", "[io][fuzz]") {
  // Found beside the crash above: get<int>() of 1e300 is a float-to-int cast out of range,
  // undefined behaviour (UBSan: "1e+300 is outside the range of representable values of type
  // 'int'"), reached by format_version, trucks_seen and site.sensors.
  auto e = posterior_error(R"({"format_version": 1e300})");
  REQUIRE(e);
  CHECK(e->field() == "format_version");
  CHECK_THAT(e->what(), Catch::Contains("must be a whole number") && Catch::Contains("1e+300"));
  e = posterior_error(R"({"format_version": 1.5})");
  REQUIRE(e);
  CHECK(e->field() == "format_version");
  e = posterior_error(R"({"format_version": 1, "method": "smc", "trucks_seen": 18446744073709551615})");
  REQUIRE(e);
  CHECK(e->field() == "trucks_seen");
  e = posterior_error(R"({"format_version": 1, "method": "smc", "trucks_seen": 3, "ess": 1,
                         "site": {"fingerprint": "f", "road": "AS1", "sensors": -3000000000}})");
  REQUIRE(e);
  CHECK(e->field() == "site.sensors");
}
