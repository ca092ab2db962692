// The stored batch-MCMC reference that ratio_benchmark --reference judges SMC fits against
// (benchmarks/stored_reference.hpp): read back field by field, and refused with the file and the
// field named when it is not one mcmc_reference_benchmark wrote.
#include <catch2/catch.hpp>

#include <string>

#include <nlohmann/json.hpp>

#include "accuracy.hpp"
#include "stored_reference.hpp"
#include "test_support.hpp"

using namespace ssrfleet;

namespace {

// A reference of the shape mcmc_reference_benchmark writes, with distinct numbers per field.
nlohmann::json reference_json() {
  nlohmann::json j = {{"benchmark", "mcmc_reference"}, {"fleet", "second"},   {"trucks", 10000},
                      {"iterations", 160000},          {"burn_in", 10000},    {"seed", 7},
                      {"commit", "abc1234"}};
  for (int h = 0; h < fleet::kHyperCount; ++h)
    j["posterior"][std::string(fleet::kHyperNames[h])] = {
        {"mean", 100.0 + h}, {"sd", 1.0 + 0.5 * h}, {"ess", 2000.0 + 10.0 * h}, {"truth", 99.0}};
  return j;
}

std::string refusal(const test::TempDir& dir, const nlohmann::json& j) {
  const std::string path = dir.file("ref.json");
  test::write_text(path, j.dump());
  try {
    bench::read_stored_reference(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("a stored MCMC reference is read back field by field", "[bench][reference]") {
  const test::TempDir dir;
  const std::string path = dir.file("ref.json");
  test::write_text(path, reference_json().dump(2));
  const bench::StoredReference r = bench::read_stored_reference(path);
  CHECK(r.path == path);
  CHECK(r.fleet == "second");
  CHECK(r.trucks == 10000);
  CHECK(r.iterations == 160000);
  CHECK(r.burn_in == 10000);
  CHECK(r.seed == 7);
  CHECK(r.commit == "abc1234");
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    CHECK(r.mean[H] == 100.0 + h);
    CHECK(r.sd[H] == 1.0 + 0.5 * h);
    CHECK(r.ess[H] == 2000.0 + 10.0 * h);
  }
  // Judged against, a fit 0.2 sd off passes and one 0.3 sd off fails (the 0.25 sd criterion).
  const bench::Reference ref{r.mean, r.sd, r.ess};
  bench::HyperSummary close{}, far{};
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    close[H].mean = r.mean[H] + 0.2 * r.sd[H];
    far[H].mean = r.mean[H] + 0.3 * r.sd[H];
    close[H].sd = far[H].sd = r.sd[H];
  }
  CHECK(bench::judge_accuracy({close}, ref, 100).verdict == bench::AccuracyVerdict::kPass);
  CHECK(bench::judge_accuracy({close, far}, ref, 100).verdict == bench::AccuracyVerdict::kFail);
}

TEST_CASE("a file that is not a stored MCMC reference is refused naming the field", "[bench][reference]") {
  const test::TempDir dir;
  CHECK_THROWS_WITH(bench::read_stored_reference(dir.file("absent.json")), Catch::Contains("cannot open"));
  test::write_text(dir.file("junk.json"), "{\"benchmark\": ");
  CHECK_THROWS_WITH(bench::read_stored_reference(dir.file("junk.json")), Catch::Contains("not JSON"));

  nlohmann::json j = reference_json();
  j["benchmark"] = "ratio";
  CHECK_THAT(refusal(dir, j), Catch::Contains("field 'benchmark' is \"ratio\""));
  j = reference_json();
  j.erase("trucks");
  CHECK_THAT(refusal(dir, j), Catch::Contains("no field 'trucks'"));
  j = reference_json();
  j["posterior"].erase("sigma_kt");
  CHECK_THAT(refusal(dir, j), Catch::Contains("no field 'posterior.sigma_kt'"));
  j = reference_json();
  j["posterior"]["Z"].erase("ess");
  CHECK_THAT(refusal(dir, j), Catch::Contains("no field 'posterior.Z.ess'"));
  j = reference_json();
  j["posterior"]["K"]["mean"] = "379080";
  CHECK_THAT(refusal(dir, j), Catch::Contains("'posterior.K.mean' is not a finite number"));
  j = reference_json();
  j["trucks"] = 1e300;
  CHECK_THAT(refusal(dir, j), Catch::Contains("field 'trucks' is not a whole number"));
  j = reference_json();
  j["seed"] = -7;
  CHECK_THAT(refusal(dir, j), Catch::Contains("field 'seed' is not a whole number"));
  j = reference_json();
  j["posterior"]["sigma_if"]["sd"] = 0.0;
  CHECK_THAT(refusal(dir, j), Catch::Contains("'posterior.sigma_if.sd' is not positive"));
  CHECK_THAT(refusal(dir, j), Catch::Contains(dir.file("ref.json")));
}
