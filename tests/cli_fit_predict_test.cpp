#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include <catch2/catch.hpp>

#include "fleet/posterior_summary.hpp"
#include "io/csv_reader.hpp"
#include "io/posterior_json.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& path) { return "'" + path + "'"; }
}  // namespace

TEST_CASE("fit then predict gives the SSR table at the sensors and the same bits for any thread count", "[cli]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 6 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const auto fit1 = run_ssrfleet("fit " + q(log) + " --particles 64 --threads 1 --seed 9 --out " + q(dir.file("p1.json")), dir);
  INFO(fit1.err);
  REQUIRE(fit1.status == 0);
  CHECK(fit1.err.find("truck 6/6") != std::string::npos);  // a progress line per truck
  const auto fit2 =
      run_ssrfleet("fit " + q(log) + " --particles 64 --threads 2 --seed 9 --quiet --out " + q(dir.file("p2.json")), dir);
  REQUIRE(fit2.status == 0);
  CHECK(fit2.err.empty());
  CHECK(test::read_text(dir.file("p1.json")) == test::read_text(dir.file("p2.json")));

  const auto pred = run_ssrfleet("predict --posterior " + q(dir.file("p1.json")) + " --draws 20 --trucks-per-draw 10 --quiet", dir);
  INFO(pred.err);
  REQUIRE(pred.status == 0);
  std::istringstream in(pred.out);
  io::CsvReader csv(in, "prediction");
  io::CsvRow row;
  REQUIRE(csv.next(row));
  CHECK(row.fields == std::vector<std::string>{"position_m", "mean_if", "lower95", "upper95", "mean_lower95", "mean_upper95"});
  int rows = 0;
  while (csv.next(row)) {
    ++rows;
    std::vector<double> v;
    for (const auto& f : row.fields) v.push_back(io::parse_finite(f, "prediction", row.line, "x"));
    CHECK(v[2] < v[1]);  // lower limit < mean < upper limit
    CHECK(v[1] < v[3]);
    CHECK(v[4] <= v[1] + 1e-12);
    CHECK(v[1] <= v[5] + 1e-12);
  }
  CHECK(rows == 16);
  // Any positions, off the sensor grid too.
  const auto anywhere = run_ssrfleet("predict --posterior " + q(dir.file("p1.json")) +
                                         " --positions 10:0.5:12 --draws 10 --trucks-per-draw 5 --quiet", dir);
  REQUIRE(anywhere.status == 0);
  CHECK(std::count(anywhere.out.begin(), anywhere.out.end(), '\n') == 6);
  // Another road only on purpose.
  const auto other = run_ssrfleet("predict --posterior " + q(dir.file("p1.json")) + " --road AS2 --quiet", dir);
  CHECK(other.status == 64);
  CHECK(other.err.find("--new-road") != std::string::npos);
  const auto fig9 =
      run_ssrfleet("predict --posterior " + q(dir.file("p1.json")) + " --road AS2 --new-road --draws 10 --trucks-per-draw 5 --quiet", dir);
  CHECK(fig9.status == 0);
  // --fixed-traffic switches the Bayesian bootstrap of the observed traffic off (its effect on
  // the band is tested in predict_ssr_test.cpp): same seed, other draws, same table shape.
  const auto fixed = run_ssrfleet("predict --posterior " + q(dir.file("p1.json")) +
                                      " --draws 20 --trucks-per-draw 10 --fixed-traffic --quiet", dir);
  REQUIRE(fixed.status == 0);
  CHECK(fixed.out != pred.out);
  CHECK(std::count(fixed.out.begin(), fixed.out.end(), '\n') == 17);
}

TEST_CASE("fit and predict refuse bad input with a clear message and no output", "[cli]") {
  test::TempDir dir;
  const std::string out = dir.file("post.json");
  const std::string log12 = dir.file("log12.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 3 --sensors 76,1.5,12 --quiet --out " + q(log12), dir).status == 0);
  SECTION("a log whose sensor count differs from the site's") {
    const auto r = run_ssrfleet("fit " + q(log12) + " --particles 16 --out " + q(out), dir);
    CHECK(r.status == 65);
    CHECK(r.err.find("12 sensors but the site has 16") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a particle count below 2") {
    const auto r = run_ssrfleet("fit " + q(log12) + " --sensors 76,1.5,12 --particles 1 --out " + q(out), dir);
    CHECK(r.status == 64);
    CHECK(r.err.find("particles") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a negative count of final sweeps") {
    const auto r = run_ssrfleet("fit " + q(log12) + " --sensors 76,1.5,12 --final-sweeps -1 --out " + q(out), dir);
    CHECK(r.status == 64);
    CHECK(r.err.find("--final-sweeps must be >= 0") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a seed that is not a number") {
    const auto r = run_ssrfleet("fit " + q(log12) + " --sensors 76,1.5,12 --seed 12x --out " + q(out), dir);
    CHECK(r.status == 64);
    CHECK(r.err.find("--seed") != std::string::npos);
  }
  SECTION("a NaN in the log names its line and field") {
    const std::string bad = dir.file("bad.csv");
    test::write_text(bad, "truck_id,speed_mps,sprung_mass_kg,if_1\nA,20,4000,1.0\nB,20,4000,nan\n");
    const auto r = run_ssrfleet("fit " + q(bad) + " --sensors 76,1.5,1 --particles 16 --out " + q(out), dir);
    CHECK(r.status == 65);
    CHECK(r.err.find(bad + ":3: field 'if_1'") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a corrupt or foreign posterior file") {
    const std::string corrupt = dir.file("corrupt.json");
    test::write_text(corrupt, "{\"K\": {\"mean\": 1");
    const auto r = run_ssrfleet("predict --posterior " + q(corrupt), dir);
    CHECK(r.status == 65);
    CHECK(r.err.find("corrupt.json") != std::string::npos);
    test::write_text(corrupt, "{\"format_version\": 1, \"method\": \"smc\"}");
    const auto r2 = run_ssrfleet("predict --posterior " + q(corrupt), dir);
    CHECK(r2.status == 65);
    CHECK(r2.err.find("trucks_seen") != std::string::npos);
    const auto r3 = run_ssrfleet("predict --posterior " + q(dir.file("missing.json")), dir);
    CHECK(r3.status == 66);
  }
}

TEST_CASE("fit --model fits the effects, records the model and its parameters, and predict uses them", "[cli][extension]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 20 --seed 3 --quiet --effect speed_bias:factor=1.1 --out " + q(log), dir).status == 0);
  const std::string post = dir.file("p.json");
  const auto fit = run_ssrfleet("fit " + q(log) + " --model speed_bias+sensor_gain:sensor=3 --particles 128 "
                                "--final-sweeps 5 --seed 2 --quiet --out " + q(post), dir);
  INFO(fit.err);
  REQUIRE(fit.status == 0);
  const auto cloud = io::read_posterior_file(post);
  CHECK(cloud.model == "speed_bias+sensor_gain:sensor=3");
  REQUIRE(cloud.psi_names == std::vector<std::string>{"speed_bias.factor", "sensor_gain.gain"});
  REQUIRE(cloud.psi.rows() == 2);
  REQUIRE(cloud.psi.cols() == 128);
  const auto psi = fleet::summarise_psi(cloud);
  // The hidden factor 1.1 inside its 95 % interval (fixed seeds: a regression, not luck), and
  // the un-gained sensor 3 near a gain of 1.
  CHECK(psi[0].q025 < 1.1);
  CHECK(psi[0].q975 > 1.1);
  CHECK(psi[1].q025 < 1.0);
  CHECK(psi[1].q975 > 1.0);
  // The file's summary holds the same numbers.
  const std::string text = test::read_text(post);
  CHECK(text.find("\"extension\"") != std::string::npos);
  const auto pred = run_ssrfleet("predict --posterior " + q(post) + " --draws 10 --trucks-per-draw 10 --quiet", dir);
  INFO(pred.err);
  CHECK(pred.status == 0);
  // The batch MCMC fits a model too.
  const auto mcmc = run_ssrfleet("fit " + q(log) + " --model speed_bias --method mcmc --iterations 600 --burn-in 200 "
                                 "--thin 2 --quiet --out " + q(dir.file("m.json")), dir);
  INFO(mcmc.err);
  REQUIRE(mcmc.status == 0);
  const auto chain = io::read_posterior_file(dir.file("m.json"));
  CHECK(chain.model == "speed_bias");
  CHECK(chain.psi.rows() == 1);
  CHECK(chain.psi.cols() == 4 * 200);  // four chains (the default) of 200 kept draws each
  CHECK(chain.chains == 4);
  const auto factor = std::find_if(chain.convergence.begin(), chain.convergence.end(),
                                   [](const fleet::ParameterConvergence& p) { return p.name == "factor"; });
  REQUIRE(factor != chain.convergence.end());
  CHECK(factor->ess_bulk > 0.0);
}

TEST_CASE("fit --model refuses a bad spec or the marginal core, listing the catalogue", "[cli][extension]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 4 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const auto out = dir.file("p.json");
  const auto bad = run_ssrfleet("fit " + q(log) + " --model sensor_gain:sensor=17 --out " + q(out), dir);
  CHECK(bad.status != 0);
  CHECK(bad.err.find("sensor_gain.sensor = '17' must be a number in [0.5, 16.5]") != std::string::npos);
  CHECK(bad.err.find("  tyre_damping: ") != std::string::npos);  // the catalogue
  const auto marginal = run_ssrfleet("fit " + q(log) + " --model sensor_gain --core marginal --out " + q(out), dir);
  CHECK(marginal.status != 0);
  CHECK(marginal.err.find("'sensor_gain' is not carried by the marginal core") != std::string::npos);
  CHECK(marginal.err.find("--core latent") != std::string::npos);
  CHECK(!std::filesystem::exists(out));
}

TEST_CASE("fit --model second_class runs on the marginal core and writes its psi", "[cli][extension][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 12 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const auto out = dir.file("p.json");
  const auto fit = run_ssrfleet("fit " + q(log) + " --model second_class --particles 128 --out " + q(out), dir);
  INFO(fit.err);
  REQUIRE(fit.status == 0);
  std::ifstream in(out);
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(fit.err.find("(marginal core)") != std::string::npos);
  CHECK(json.find("\"psi\"") != std::string::npos);
  CHECK(json.find("\"model\": \"second_class\"") != std::string::npos);
  CHECK(json.find("\"sigma_k2\"") != std::string::npos);
}

TEST_CASE("fit --chains out of range is a usage error naming the option, and writes nothing", "[cli][mcmc]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 4 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const auto out = dir.file("p.json");
  for (const char* chains : {"0", "65"}) {
    const auto r = run_ssrfleet("fit " + q(log) + " --method mcmc --chains " + chains + " --iterations 50 --burn-in 10 --out " + q(out), dir);
    INFO(r.err);
    CHECK(r.status == 64);
    CHECK(r.err.find("chains") != std::string::npos);
    CHECK(!std::filesystem::exists(out));
  }
}
