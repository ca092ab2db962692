// Every crash the fuzz harnesses (fuzz/, CONTRIBUTING.md) found, as the input that crashed, now a
// clean DataError naming the file and the field. Each case says which harness found it and what
// the crash was.
#include <chrono>
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/posterior_json.hpp"
#include "road/erd_format.hpp"
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

TEST_CASE("a positions range FIRST:STEP:LAST past a long or not finite is a usage error", "[cli][fuzz]") {
  // site_options_fuzzer, crash-8d93e652: --positions "13:0.05:7.697e51" (written out in digits) asked for 1.5e53 positions, and
  // static_cast<long> of that is undefined behaviour (UBSan: "1.5394e+53 is outside the range of
  // representable values of type 'long'"); in a plain build it came out negative and predict
  // silently used the default positions.
  test::TempDir dir;
  const std::string posterior = dir.file("posterior.json");
  test::write_text(posterior,
                   R"({"trucks_seen": 3, "particles": 2, "ess": 1.9, "method": "smc", "model": "base", "format_version": 1,
  "site": {"fingerprint": "f", "road": "AS1", "sensors": 16, "lateral_min_m": 0.0, "lateral_max_m": 5.0},
  "cloud": {"weights": [0.5, 0.5], "speed_mps": [23.1, 21.0], "sprung_mass_kg": [4450, 4300],
            "theta": [[5e5, 5e4, 1.95e6, 1.95e5, 1.5, 0.5, 0.02], [5.05e5, 5.05e4, 1.97e6, 1.97e5, 1.52, 0.51, 0.021]]}})");
  for (const char* positions : {"13:0.05:7697000000000000000000000000000000000000000000000000", "0:1e-300:1", "nan:1:2"}) {
    INFO(positions);
    const auto r = test::run_ssrfleet("predict --posterior '" + posterior + "' --new-road --quiet --positions '" +
                                          positions + "'",
                                      dir);
    CHECK(r.status == 64);
    CHECK_THAT(r.err, Catch::Contains(std::string("--positions '") + positions + "'"));
  }
}

TEST_CASE("an ERD header that declares millions of channels costs what its bytes do, and is refused as truncated",
          "[road][fuzz]") {
  // fuzz/erd_fuzzer, a timeout: NCHAN = 1e6 and a header of many SHORTNAM and UNITSNAM lines, each
  // split into a million fields as it was read (4 s for 5 kB; minutes for this input). The fields
  // are now split once, after the data are known to hold the channels.
  std::string text = "ERDFILEV2.00\n1000000,100,5,0.05,-11,1,5,0.05,-1\n";
  for (int i = 0; i < 2000; ++i) text += "SHORTNAMpr1\nUNITSNAMmm\n";
  text += "END\n1 2 3\n";
  const auto start = std::chrono::steady_clock::now();
  auto e = data_error([&] { road::read_erd(text, "fuzzed.erd"); });
  // The old reader gave the same error after more than 60 s; this one takes milliseconds (10 s
  // leaves room for a sanitized build on a loaded machine).
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < 10.0);
  REQUIRE(e);
  CHECK(e->field() == "data");
  CHECK(e->reason().find("truncated") != std::string::npos);
  // 5e7 channels of 2 samples: the per-channel labels and units (3 GB of strings) were allocated
  // before the data were counted.
  text = "ERDFILEV2.00\n50000000,2,5,0.05,-11,1,5,0.05,-1\nSHORTNAMa\nEND\n1 2\n";
  e = data_error([&] { road::read_erd(text, "fuzzed.erd"); });
  REQUIRE(e);
  CHECK(e->field() == "data");
  // A unit is still checked before the data: an unknown one is named with its channel.
  text = "ERDFILEV2.00\n2,3,5,0.05,-11,1,5,0.05,-1\nUNITSNAMmm      furlong\nEND\n1 2\n";
  e = data_error([&] { road::read_erd(text, "fuzzed.erd"); });
  REQUIRE(e);
  CHECK(e->field() == "UNITSNAM");
  CHECK(e->reason().find("'furlong' of channel 2") != std::string::npos);
}
