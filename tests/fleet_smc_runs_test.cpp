#include <cmath>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_real_distribution.hpp>
#include <catch2/catch.hpp>

#include "fleet/smc_runs.hpp"
#include "io/posterior_json.hpp"
#include "model/fleet_model.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& path) { return "'" + path + "'"; }

// A run's cloud: P particles, each hyperparameter N(shift, 1) with weights uniform on [0.5, 1.5]
// (so not all equal), or all equal.
fleet::PosteriorCloud run_cloud(Eigen::Index P, double shift, std::uint32_t seed, bool equal_weights = false) {
  boost::random::mt19937 rng(seed);
  boost::random::normal_distribution<double> normal;
  boost::random::uniform_real_distribution<double> uniform(0.5, 1.5);
  fleet::PosteriorCloud c;
  c.method = "smc";
  c.theta.resize(fleet::kHyperCount, P);
  for (Eigen::Index i = 0; i < P; ++i)
    for (int j = 0; j < fleet::kHyperCount; ++j) c.theta(j, i) = shift + normal(rng);
  c.weights.resize(P);
  for (Eigen::Index i = 0; i < P; ++i) c.weights[i] = equal_weights ? 1.0 : uniform(rng);
  c.weights /= c.weights.sum();
  c.weight_ess = 1.0 / c.weights.square().sum();
  c.speed_mps = {20.0};
  c.sprung_mass_kg = {15000.0};
  c.site_fingerprint = "site";
  c.trucks_seen = 1;
  c.log_evidence = -10.0 - 0.1 * seed;
  return c;
}
}  // namespace

TEST_CASE("SMC runs pool run after run, each run's weights summing to 1/R, with their diagnostics", "[fleet][runs]") {
  std::vector<fleet::PosteriorCloud> runs;
  for (std::uint32_t r = 0; r < 3; ++r) runs.push_back(run_cloud(50, 0.0, 11 + r));
  const fleet::PosteriorCloud pooled = fleet::pool_runs(runs);
  REQUIRE(pooled.theta.cols() == 150);
  CHECK(pooled.chains == 3);
  double inverse_ess = 0.0, evidence = 0.0;
  for (Eigen::Index r = 0; r < 3; ++r) {
    const auto& run = runs[static_cast<std::size_t>(r)];
    CHECK(pooled.theta.middleCols(r * 50, 50) == run.theta);
    CHECK(pooled.weights.segment(r * 50, 50).sum() == Approx(1.0 / 3.0).epsilon(1e-12));
    CHECK((pooled.weights.segment(r * 50, 50) * 3.0 - run.weights).abs().maxCoeff() < 1e-15);
    inverse_ess += 1.0 / run.weight_ess;
    evidence += std::exp(run.log_evidence);
  }
  // The ESS of every particle weighted w/R is (Σ w/R)² / Σ (w/R)² = R² / Σ_r 1/ESS_r.
  CHECK(pooled.weight_ess == Approx(9.0 / inverse_ess).epsilon(1e-12));
  CHECK(pooled.weight_ess == Approx(1.0 / pooled.weights.square().sum()).epsilon(1e-12));
  CHECK(pooled.log_evidence == Approx(std::log(evidence / 3.0)).epsilon(1e-12));
  // The MCSE of each mean is the sd of the runs' weighted means over √R, computed here afresh.
  REQUIRE(pooled.convergence.size() == static_cast<std::size_t>(fleet::kHyperCount));
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    std::vector<double> means;
    for (const auto& run : runs) means.push_back((run.theta.row(j).transpose().array() * run.weights).sum());
    const double m = (means[0] + means[1] + means[2]) / 3.0;
    double ss = 0.0;
    for (double x : means) ss += (x - m) * (x - m);
    const auto& p = pooled.convergence[static_cast<std::size_t>(j)];
    CHECK(p.name == fleet::kHyperNames[static_cast<std::size_t>(j)]);
    CHECK(p.mcse_mean == Approx(std::sqrt(ss / 2.0) / std::sqrt(3.0)).epsilon(1e-12));
    CHECK(std::isnan(p.ess_bulk));
    CHECK(std::isnan(p.ess_tail));
    CHECK(p.ess_equivalent > 0.0);
    CHECK(p.mcse_q05 > 0.0);
    CHECK(p.mcse_q95 > 0.0);
  }
  // One run is returned as it is.
  const fleet::PosteriorCloud one = fleet::pool_runs({runs[0]});
  CHECK(one.chains == 1);
  CHECK(one.theta == runs[0].theta);
  CHECK(one.convergence.empty());
}

TEST_CASE("the runs' MCSE of the mean estimates the pooled mean's Monte Carlo error without bias", "[fleet][runs]") {
  // 400 sets of R = 4 runs, each of P = 200 independent N(0, 1) draws with equal weights: the
  // pooled mean has variance 1/(P R), and mcse² = var_r(means)/R (divisor R - 1) is unbiased for
  // it. P R mcse² ~ χ²(3)/3 has sd √(2/3), so its mean over 400 sets is 1 within 0.041 (1 sd);
  // 0.17 is 4 sd. The equivalent ESS var/mcse² follows: its median is P R / (median of χ²(3)/3 =
  // 0.789) = 1,014 in theory, against the 800 draws pooled.
  const Eigen::Index P = 200;
  const int R = 4, sets = 400;
  double scaled = 0.0;
  std::vector<double> ess;
  for (int s = 0; s < sets; ++s) {
    std::vector<fleet::PosteriorCloud> runs;
    for (int r = 0; r < R; ++r) runs.push_back(run_cloud(P, 0.0, static_cast<std::uint32_t>(1000 + s * R + r), true));
    const auto c = fleet::run_convergence(runs);
    scaled += static_cast<double>(P * R) * c[0].mcse_mean * c[0].mcse_mean / sets;
    ess.push_back(c[0].ess_equivalent);
  }
  INFO("mean of P R mcse^2 " << scaled);
  CHECK(std::abs(scaled - 1.0) < 0.17);
  std::sort(ess.begin(), ess.end());
  const double median = 0.5 * (ess[sets / 2 - 1] + ess[sets / 2]);
  // The sample median of 400 has an sd of about 1/(2 f √400) on the χ²(3)/3 scale, f = 0.56 the
  // density at the median, so 0.044 there, or 5.6 % of the median: 30 % is over 5 sd.
  INFO("median equivalent ESS " << median);
  CHECK(median == Approx(800.0 / 0.789).epsilon(0.30));
}

TEST_CASE("runs that disagree by 3 sd give R-hat far above 1, runs that agree near 1", "[fleet][runs]") {
  std::vector<fleet::PosteriorCloud> agree, shifted;
  for (std::uint32_t r = 0; r < 4; ++r) {
    agree.push_back(run_cloud(2000, 0.0, 21 + r));
    shifted.push_back(run_cloud(2000, r == 3 ? 3.0 : 0.0, 21 + r));
  }
  // Equal-weight draws of weighted clouds repeat some particles, so the runs' within variance is
  // a little below an iid sample's, but B/W stays of order 1/P: R-hat - 1 ~ 1/(2 P) = 0.00025.
  for (const auto& p : fleet::run_convergence(agree)) {
    INFO(p.name << ": R-hat " << p.rhat);
    CHECK(p.rhat < 1.005);
  }
  for (const auto& p : fleet::run_convergence(shifted)) {
    INFO(p.name << ": R-hat " << p.rhat);
    CHECK(p.rhat > 1.3);
  }
}

TEST_CASE("runs of another shape, site or log are refused by name", "[fleet][runs]") {
  const fleet::PosteriorCloud a = run_cloud(50, 0.0, 1);
  fleet::PosteriorCloud fewer = run_cloud(40, 0.0, 2), other_site = run_cloud(50, 0.0, 3), other_log = run_cloud(50, 0.0, 4);
  other_site.site_fingerprint = "elsewhere";
  other_log.trucks_seen = 2;
  CHECK_THROWS_WITH(fleet::pool_runs({a, fewer}), Catch::Contains("run 2") && Catch::Contains("particles"));
  CHECK_THROWS_WITH(fleet::pool_runs({a, a, other_site}), Catch::Contains("run 3") && Catch::Contains("site"));
  CHECK_THROWS_WITH(fleet::pool_runs({a, other_log}), Catch::Contains("trucks"));
  CHECK_THROWS_WITH(fleet::run_convergence({a}), Catch::Contains("2 runs"));
}

TEST_CASE("run seeds: run 1 is the seed itself, the others distinct", "[fleet][runs]") {
  std::set<std::uint64_t> seen;
  CHECK(fleet::run_seed(42, 0) == 42);
  for (int r = 0; r < 64; ++r) seen.insert(fleet::run_seed(42, r));
  CHECK(seen.size() == 64);
  CHECK(fleet::run_seed(43, 1) != fleet::run_seed(42, 1));
}

TEST_CASE("fit --runs 2 pools two runs, the first the plain fit, and keeps their diagnostics", "[cli][runs][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 4 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const std::string common = " --particles 48 --final-sweeps 1 --seed 9 --threads 2";
  const auto one = run_ssrfleet("fit " + q(log) + common + " --quiet --out " + q(dir.file("one.json")), dir);
  REQUIRE(one.status == 0);
  const auto two = run_ssrfleet("fit " + q(log) + common + " --runs 2 --out " + q(dir.file("two.json")), dir);
  INFO(two.err);
  REQUIRE(two.status == 0);
  CHECK(two.err.find("run 2/2") != std::string::npos);
  CHECK(two.err.find("equivalent ESS") != std::string::npos);
  const fleet::PosteriorCloud a = io::read_posterior_file(dir.file("one.json"));
  const fleet::PosteriorCloud b = io::read_posterior_file(dir.file("two.json"));
  REQUIRE(b.theta.cols() == 2 * a.theta.cols());
  CHECK(b.chains == 2);
  CHECK(b.method == "smc");
  // Run 1 is the plain fit bit for bit (the file keeps 17 significant digits).
  CHECK(b.theta.leftCols(a.theta.cols()) == a.theta);
  CHECK(b.theta.middleCols(a.theta.cols(), a.theta.cols()) != a.theta);
  REQUIRE(b.convergence.size() == static_cast<std::size_t>(fleet::kHyperCount));
  for (const auto& p : b.convergence) {
    INFO(p.name);
    CHECK(p.rhat > 0.9);
    CHECK(p.ess_equivalent > 0.0);
    CHECK(std::isnan(p.ess_bulk));
  }
  CHECK(a.weight_ess > 0.0);
  CHECK(test::read_text(dir.file("two.json")).find("\"weight_ess\"") != std::string::npos);
  CHECK(test::read_text(dir.file("two.json")).find("\"ess_equivalent\"") != std::string::npos);
}

TEST_CASE("fit --runs out of range or with the MCMC is a usage error, and so is --chains with the SMC",
          "[cli][runs]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 3 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const auto out = dir.file("p.json");
  for (const std::string& bad : {std::string(" --runs 0"), std::string(" --runs 65"),
                                 std::string(" --runs 2 --method mcmc --iterations 50 --burn-in 10"),
                                 std::string(" --chains 2")}) {
    const auto r = run_ssrfleet("fit " + q(log) + " --particles 16" + bad + " --out " + q(out), dir);
    INFO(bad << ": " << r.err);
    CHECK(r.status == 64);
    CHECK((r.err.find("--runs") != std::string::npos || r.err.find("--chains") != std::string::npos));
    CHECK(!std::filesystem::exists(out));
  }
}
