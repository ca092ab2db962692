// `ssrfleet diagnose` and `simulate --effect` through the command line: the report files, and
// bad input refused with a message and the documented exit status, before any long work.
#include <filesystem>

#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>

#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& path) { return "'" + path + "'"; }
}  // namespace

TEST_CASE("diagnose on a small log writes the JSON report and the per-sensor files", "[cli][diagnose]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  const auto sim = run_ssrfleet("simulate --trucks 12 --seed 4 --quiet --effect sensor_gain:sensor=3,gain=1.1 --out " + q(log), dir);
  INFO(sim.err);
  REQUIRE(sim.status == 0);
  CHECK(test::read_text(log).find("model sensor_gain:sensor=3,gain=1.1") != std::string::npos);  // in the header comment
  const auto r = run_ssrfleet("diagnose " + q(log) + " --particles 64 --draws 20 --candidates sensor_gain --no-plots --json " +
                                  q(dir.file("report.json")) + " --out " + q(dir.file("diag")) + " --posterior-out " +
                                  q(dir.file("ends.json")),
                              dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("diagnose: fitting the base model") != std::string::npos);  // progress on stderr
  CHECK(r.out.find("# ssrfleet diagnose") != std::string::npos);               // the summary on stdout
  const auto j = nlohmann::json::parse(test::read_text(dir.file("report.json")));
  CHECK(j.contains("effect"));
  CHECK(j["candidates"].size() == 1);
  for (const char* f : {"summary.md", "report.json", "residual_pattern.csv", "per_sensor_checks.csv", "checks.csv",
                        "residual_pattern.gp", "checks.gp", "posterior.json"}) {
    INFO(f);
    CHECK(std::filesystem::exists(dir.path() / "diag" / f));
  }
  // The posterior diagnose ends with is the chosen effect's model (or the base), and predict takes it.
  const auto post = nlohmann::json::parse(test::read_text((dir.path() / "diag" / "posterior.json").string()));
  const std::string effect = j["effect"].get<std::string>();
  CHECK(post["model"] == j["model"]);
  if (effect == "sensor_gain") {
    // Refitted with the sensor fixed where the checks point (sensor 3), its gain fitted.
    CHECK(j["model"] == "sensor_gain:sensor=3");
    CHECK(post["extension"].size() == 1);
    CHECK(post["extension"].contains("gain"));
  } else {
    CHECK(j["model"] == "base");
  }
  // --posterior-out writes the same posterior where it is asked for.
  CHECK(test::read_text(dir.file("ends.json")) == test::read_text((dir.path() / "diag" / "posterior.json").string()));
  const auto pred = run_ssrfleet("predict --posterior " + q((dir.path() / "diag" / "posterior.json").string()) +
                                     " --draws 10 --trucks-per-draw 10 --quiet", dir);
  INFO(pred.err);
  CHECK(pred.status == 0);
}

TEST_CASE("diagnose and simulate --effect refuse bad input with a clear message and exit status", "[cli][diagnose]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 10 --seed 1 --quiet --out " + q(log), dir).status == 0);

  auto r = run_ssrfleet("simulate --trucks 5 --effect wind:speed=3 --quiet --out " + q(dir.file("w.csv")), dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("unknown effect 'wind'") != std::string::npos);
  CHECK(r.err.find("  sensor_gain: ") != std::string::npos);  // the catalogue
  CHECK(!std::filesystem::exists(dir.file("w.csv")));
  r = run_ssrfleet("simulate --trucks 5 --effect tyre_damping:c_t=-3 --quiet --out " + q(dir.file("w.csv")), dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("tyre_damping.c_t = '-3' must be a number in [0, 10000]") != std::string::npos);

  // The posterior diagnose writes is an output: --posterior-out; --posterior (what predict, damage and
  // weigh read) is refused by name, not taken as an abbreviation of --posterior-out.
  r = run_ssrfleet("diagnose " + q(log) + " --posterior " + q(dir.file("p.json")), dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("--posterior-out FILE") != std::string::npos);
  CHECK(!std::filesystem::exists(dir.file("p.json")));

  r = run_ssrfleet("diagnose " + q(dir.file("missing.csv")), dir);
  CHECK(r.status == 66);
  r = run_ssrfleet("diagnose " + q(log) + " --candidates sensor_gain,wind", dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("unknown model extension 'wind'") != std::string::npos);
  r = run_ssrfleet("diagnose " + q(log) + " --particles 1", dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("particles") != std::string::npos);
  r = run_ssrfleet("diagnose " + q(log) + " --seed x", dir);
  CHECK(r.status == 64);
  r = run_ssrfleet("diagnose " + q(log) + " --sensors 76,1.5,12", dir);
  CHECK(r.status == 65);
  CHECK(r.err.find("the log has 16 sensors but the site has 12") != std::string::npos);
}
