#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <boost/math/distributions/binomial.hpp>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_01.hpp>
#include <boost/random/uniform_real_distribution.hpp>
#include <catch2/catch.hpp>

#include "discrepancy/posterior_checks.hpp"

using namespace ssrfleet;
using discrepancy::CheckOptions;
using discrepancy::CheckReport;
using discrepancy::CheckResult;
using discrepancy::PosteriorDraws;
using fleet::CheckKind;

namespace {

constexpr Eigen::Index kSensors = 16;
constexpr Eigen::Index kTrucks = 100;
constexpr int kDraws = 50;
constexpr double kSigma = 0.02;
constexpr int kReplicates = 4000;

const CheckResult& check(const CheckReport& report, CheckKind kind) {
  return report.checks.at(static_cast<std::size_t>(kind));
}

// The smallest p-value the checks can return: the observed data beat every replicate.
double smallest_p(int replicates) { return 1.0 / (1.0 + replicates); }

// A synthetic fitted fleet, no simulation needed. The truth f_true is a smooth pattern along the
// array plus each truck's own smooth variation; y = f_true + noise of sd σ, an AR(1) along the
// array with the given neighbour correlation (0: white, as the model says). The posterior draws
// jitter each truck's curve by a tenth of σ and σ by its posterior sd 1/sqrt(2 N M), as a
// well-identified fit would, so the checks should find nothing unless a test plants something.
// Speed, sprung mass and lateral position are drawn independently of each other and of f.
// Posterior draws of F(k_i) for kTrucks trucks whose standardised stiffnesses come from
// `standardised` and are compared with N(0, 1): each draw jitters k_i by a tenth of the fleet sd,
// as a well-identified fit would. A stream of its own, so the other draws stay as they were.
template <class Draw>
std::vector<Eigen::VectorXd> stiffness_pit_draws(std::uint64_t seed, Draw standardised) {
  boost::random::mt19937_64 engine(seed ^ 0x6b6bULL);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd k(kTrucks);
  for (Eigen::Index i = 0; i < kTrucks; ++i) k[i] = standardised(engine);
  std::vector<Eigen::VectorXd> pit;
  for (int d = 0; d < kDraws; ++d) {
    Eigen::VectorXd u(kTrucks);
    for (Eigen::Index i = 0; i < kTrucks; ++i) u[i] = 0.5 * std::erfc(-(k[i] + 0.1 * normal(engine)) / std::sqrt(2.0));
    pit.push_back(u);
  }
  return pit;
}

PosteriorDraws make_draws(std::uint64_t seed, double neighbour_correlation = 0.0) {
  boost::random::mt19937_64 engine(seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  boost::random::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double pi = std::acos(-1.0);
  const Eigen::ArrayXd along = Eigen::ArrayXd::LinSpaced(kSensors, 0.0, 1.0);  // position on the array

  PosteriorDraws draws;
  draws.speed_mps.resize(kTrucks);
  draws.sprung_mass_kg.resize(kTrucks);
  Eigen::VectorXd lateral_true(kTrucks);
  Eigen::MatrixXd f_true(kSensors, kTrucks);
  for (Eigen::Index i = 0; i < kTrucks; ++i) {
    draws.speed_mps[i] = 15.0 + 10.0 * uniform(engine);
    draws.sprung_mass_kg[i] = 8000.0 + 8000.0 * uniform(engine);
    lateral_true[i] = 0.5 + uniform(engine);
    const double a = normal(engine), b = normal(engine);
    f_true.col(i) = 1.0 + 0.05 * (2.6 * pi * along).sin() + 0.03 * a * (pi * along).cos() + 0.02 * b * along;
  }

  const double innovation_sd = kSigma * std::sqrt(1.0 - neighbour_correlation * neighbour_correlation);
  draws.observed = f_true;
  for (Eigen::Index i = 0; i < kTrucks; ++i) {
    double noise = kSigma * normal(engine);  // stationary start: marginal sd σ at every sensor
    draws.observed(0, i) += noise;
    for (Eigen::Index m = 1; m < kSensors; ++m) {
      noise = neighbour_correlation * noise + innovation_sd * normal(engine);
      draws.observed(m, i) += noise;
    }
  }

  const double sigma_posterior_sd = kSigma / std::sqrt(2.0 * kTrucks * kSensors);
  for (int d = 0; d < kDraws; ++d) {
    Eigen::MatrixXd f = f_true;
    Eigen::VectorXd lateral = lateral_true;
    for (Eigen::Index i = 0; i < kTrucks; ++i) {
      f.col(i).array() += 0.1 * kSigma * (normal(engine) * (pi * along).cos() + 0.5 * normal(engine));
      lateral[i] += 0.05 * normal(engine);
    }
    draws.model_if.push_back(f);
    draws.lateral_m.push_back(lateral);
    draws.sigma_if.push_back(kSigma + sigma_posterior_sd * normal(engine));
  }
  draws.stiffness_pit = stiffness_pit_draws(seed, [](boost::random::mt19937_64& e) {
    return boost::random::normal_distribution<double>(0.0, 1.0)(e);
  });
  // The tyre stiffnesses' stream is another again (stiffness_pit_draws XORs its seed).
  draws.tyre_stiffness_pit = stiffness_pit_draws(seed ^ 0x7474ULL, [](boost::random::mt19937_64& e) {
    return boost::random::normal_distribution<double>(0.0, 1.0)(e);
  });
  return draws;
}

CheckOptions options_with(int replicates, std::uint64_t seed, double alpha = 0.01) {
  CheckOptions options;
  options.replicates = replicates;
  options.seed = seed;
  options.alpha = alpha;
  return options;
}

// The largest count k that X ~ Binomial(n, p) exceeds with probability at most `tail`.
int binomial_upper_bound(int n, double p, double tail) {
  const boost::math::binomial_distribution<double> x(n, p);
  int k = 0;
  while (boost::math::cdf(boost::math::complement(x, k)) > tail) ++k;
  return k;
}

// Mean and sd of the maximum of k iid non-negative variables with CDF F, from
// E[X] = ∫ (1 - F(t)^k) dt and E[X²] = ∫ 2t (1 - F(t)^k) dt over [0, upper].
template <class Cdf>
std::pair<double, double> max_moments(Cdf F, int k, double upper) {
  using Quadrature = boost::math::quadrature::gauss_kronrod<double, 61>;
  const auto survival = [&](double t) { return 1.0 - std::pow(F(t), k); };
  const double m1 = Quadrature::integrate(survival, 0.0, upper, 15, 1e-12);
  const double m2 =
      Quadrature::integrate([&](double t) { return 2.0 * t * survival(t); }, 0.0, upper, 15, 1e-12);
  return {m1, std::sqrt(m2 - m1 * m1)};
}

// Replicated means are averages of R independent replicates: allow 5 Monte Carlo sd.
void check_replicated_mean(const CheckResult& result, double mean, double sd, int replicates) {
  INFO(fleet::check_name(result.kind) << ": replicated " << result.replicated << ", expected " << mean);
  CHECK(std::abs(result.replicated - mean) < 5.0 * sd / std::sqrt(replicates));
}

// A strong planted effect: the observed statistic beat (nearly) every replicate.
void check_found(const CheckResult& result, int replicates) {
  INFO(fleet::check_name(result.kind)
       << ": p = " << result.p_value << ", T = " << result.statistic << ", replicated " << result.replicated);
  CHECK(result.flagged);
  CHECK(result.p_value <= 2.0 * smallest_p(replicates));
}

void check_not_found(const CheckResult& result) {
  INFO(fleet::check_name(result.kind) << ": p = " << result.p_value);
  CHECK_FALSE(result.flagged);
}

}  // namespace

TEST_CASE("posterior checks report one result per family in enum order", "[checks]") {
  const CheckReport report = discrepancy::run_checks(make_draws(1), options_with(200, 1));
  REQUIRE(report.checks.size() == static_cast<std::size_t>(CheckKind::kCount));
  for (std::size_t k = 0; k < report.checks.size(); ++k) {
    const CheckResult& result = report.checks[k];
    CHECK(static_cast<std::size_t>(result.kind) == k);
    CHECK(result.flagged == (result.p_value < 0.01));
    CHECK(result.p_value >= smallest_p(200));
    CHECK(result.p_value <= 1.0);
    if (result.kind == CheckKind::kAutocorrelation || result.kind == CheckKind::kStiffnessDistribution ||
        result.kind == CheckKind::kLatentCovariates) {
      CHECK(result.per_sensor.empty());
      CHECK(result.sensor == 0);
    } else {
      CHECK(result.per_sensor.size() == static_cast<std::size_t>(kSensors));
      CHECK(result.sensor >= 1);
      CHECK(result.sensor <= kSensors);
    }
  }
  CHECK(report.gap.mean_residual.size() == static_cast<std::size_t>(kSensors));
  CHECK(report.gap.standardised_mean.size() == static_cast<std::size_t>(kSensors));
}

TEST_CASE("posterior checks of a correct model give uniform p-values and calibrated gaps", "[checks]") {
  // 20 independent data sets, each checked with 500 replicates (p resolves 0.002, fine at 0.05).
  constexpr int kDataSets = 20, kFewReplicates = 500;
  constexpr auto kFamilies = static_cast<std::size_t>(CheckKind::kCount);
  std::vector<std::vector<double>> p_values(kFamilies);
  // Under the model Σ_m z_m² ~ χ²_M, so rms² = χ²_M / M; allow each data set a 1e-4 tail either side.
  const boost::math::chi_squared_distribution<double> chi2(kSensors);
  const double rms_lo = std::sqrt(boost::math::quantile(chi2, 1e-4) / kSensors);
  const double rms_hi = std::sqrt(boost::math::quantile(boost::math::complement(chi2, 1e-4)) / kSensors);
  // Coverage: a binomial share of N M points, ±4 sd (the draws' jitter widens it by under 0.2 %).
  const double coverage_sd = std::sqrt(0.95 * 0.05 / static_cast<double>(kTrucks * kSensors));
  for (int s = 1; s <= kDataSets; ++s) {
    const auto seed = static_cast<std::uint64_t>(s);
    const CheckReport report =
        discrepancy::run_checks(make_draws(seed), options_with(kFewReplicates, 1000 + seed));
    for (std::size_t k = 0; k < kFamilies; ++k) p_values[k].push_back(report.checks[k].p_value);
    INFO("data set " << s << ": rms " << report.gap.rms_standardised_mean << ", coverage "
                     << report.gap.coverage95);
    CHECK(report.gap.rms_standardised_mean > rms_lo);
    CHECK(report.gap.rms_standardised_mean < rms_hi);
    CHECK(std::abs(report.gap.coverage95 - 0.95) < 4.0 * coverage_sd);
  }
  // Uniform p-values: few below 0.05 (a bound Binomial(20, 0.05) exceeds with probability 1e-3),
  // and not all piled at one end (their mean within 4 sd of 1/2, sd = sqrt(1/12 / 20)).
  const int max_small = binomial_upper_bound(kDataSets, 0.05, 1e-3);
  for (std::size_t k = 0; k < kFamilies; ++k) {
    const auto& p = p_values[k];
    const auto small = std::count_if(p.begin(), p.end(), [](double v) { return v < 0.05; });
    const double mean = std::accumulate(p.begin(), p.end(), 0.0) / kDataSets;
    INFO(fleet::check_name(static_cast<CheckKind>(k))
         << ": " << small << " p-values below 0.05, mean " << mean);
    CHECK(small <= max_small);
    CHECK(std::abs(mean - 0.5) < 4.0 * std::sqrt(1.0 / 12.0 / kDataSets));
  }
}

TEST_CASE("replicated statistics follow their distributions under the model", "[checks]") {
  const CheckReport report = discrepancy::run_checks(make_draws(2), options_with(kReplicates, 2));
  const double N = kTrucks, M = kSensors;

  // kSensorMean: z_m = sqrt(N) mean(ε) is exactly N(0, 1), so T is the largest of M iid |N(0, 1)|.
  const auto [mean_max_z, sd_max_z] =
      max_moments([](double t) { return std::erf(t / std::sqrt(2.0)); }, kSensors, 12.0);
  check_replicated_mean(check(report, CheckKind::kSensorMean), mean_max_z, sd_max_z, kReplicates);

  // kSensorDispersion: N ρ_m ~ χ²_{N-1} exactly, so T is the largest of M iid χ²_{N-1} / N.
  const boost::math::chi_squared_distribution<double> chi2(N - 1.0);
  const auto [mean_max_rho, sd_max_rho] =
      max_moments([&](double t) { return boost::math::cdf(chi2, N * t); }, kSensors, 4.0);
  check_replicated_mean(check(report, CheckKind::kSensorDispersion), mean_max_rho, sd_max_rho, kReplicates);

  // Covariates: the correlation of a fixed vector with iid normal noise has c² ~ Beta(1/2, (N-2)/2),
  // so N Σ_m c_m² has mean M N / (N - 1) and variance M N² 2 (N - 2) / ((N - 1)² (N + 1)).
  const double mean_cov = M * N / (N - 1.0);
  const double sd_cov = std::sqrt(M * N * N * 2.0 * (N - 2.0) / ((N - 1.0) * (N - 1.0) * (N + 1.0)));
  for (CheckKind kind : {CheckKind::kSpeed, CheckKind::kMass, CheckKind::kLateral}) {
    check_replicated_mean(check(report, kind), mean_cov, sd_cov, kReplicates);
  }

  // kStiffnessDistribution: Anderson-Darling A² of N uniforms has mean 1 and variance
  // 2 (π² - 9) / 3 + (10 - π²) / N (Anderson & Darling 1954).
  const double pi2 = std::acos(-1.0) * std::acos(-1.0);
  check_replicated_mean(check(report, CheckKind::kStiffnessDistribution), 1.0,
                        std::sqrt(2.0 * (pi2 - 9.0) / 3.0 + (10.0 - pi2) / N), kReplicates);
}

TEST_CASE("posterior checks are reproducible for a seed and the observed statistic does not depend on it",
          "[checks]") {
  const PosteriorDraws draws = make_draws(3);
  const CheckReport a = discrepancy::run_checks(draws, options_with(1000, 7));
  const CheckReport b = discrepancy::run_checks(draws, options_with(1000, 7));
  const CheckReport c = discrepancy::run_checks(draws, options_with(1000, 8));
  for (std::size_t k = 0; k < a.checks.size(); ++k) {
    CHECK(a.checks[k].p_value == b.checks[k].p_value);
    CHECK(a.checks[k].replicated == b.checks[k].replicated);
    CHECK(a.checks[k].statistic == c.checks[k].statistic);
    CHECK(a.checks[k].replicated != c.checks[k].replicated);
  }
  CHECK(a.gap.coverage95 == c.gap.coverage95);
}

// The planted-effect tests flag at alpha = 0.001: a planted effect still reaches the smallest
// p-value 1/4001, and a family with nothing planted is then wrongly flagged with probability 0.1 %.
TEST_CASE("a 5 percent gain on sensor 7 fails the sensor-mean check at sensor 7", "[checks]") {
  PosteriorDraws draws = make_draws(4);
  draws.observed.row(6) *= 1.05;
  const CheckReport report = discrepancy::run_checks(draws, options_with(kReplicates, 4, 1e-3));
  const CheckResult& mean = check(report, CheckKind::kSensorMean);
  check_found(mean, kReplicates);
  CHECK(mean.sensor == 7);
  // The offset is 0.05 against σ / sqrt(N) = 0.002: z ≈ 25 at one sensor of 16, rms ≈ 6.
  CHECK(report.gap.rms_standardised_mean > 5.0);
  check_not_found(check(report, CheckKind::kSpeed));
  check_not_found(check(report, CheckKind::kMass));
}

TEST_CASE("a residual trend with speed fails the speed check and not the mass check", "[checks]") {
  PosteriorDraws draws = make_draws(5);
  const Eigen::ArrayXd v = draws.speed_mps.array();
  const double sd = std::sqrt((v - v.mean()).square().mean());
  // Centred across trucks, so it leaves every sensor's mean residual alone.
  const Eigen::RowVectorXd trend = (0.01 * (v - v.mean()) / sd).matrix().transpose();
  draws.observed.rowwise() += trend;
  const CheckReport report = discrepancy::run_checks(draws, options_with(kReplicates, 5, 1e-3));
  check_found(check(report, CheckKind::kSpeed), kReplicates);
  check_not_found(check(report, CheckKind::kMass));
  check_not_found(check(report, CheckKind::kLateral));
  check_not_found(check(report, CheckKind::kSensorMean));
}

TEST_CASE("extra noise at sensor 3 fails the dispersion check at sensor 3", "[checks]") {
  PosteriorDraws draws = make_draws(6);
  boost::random::mt19937_64 engine(60);
  boost::random::normal_distribution<double> normal(0.0, 0.03);
  for (Eigen::Index i = 0; i < kTrucks; ++i) draws.observed(2, i) += normal(engine);
  const CheckReport report = discrepancy::run_checks(draws, options_with(kReplicates, 6, 1e-3));
  const CheckResult& dispersion = check(report, CheckKind::kSensorDispersion);
  check_found(dispersion, kReplicates);
  CHECK(dispersion.sensor == 3);
  // ρ_3 ≈ (0.02² + 0.03²) / 0.02² = 3.25 with sd about 3.25 sqrt(2 / N) = 0.46.
  CHECK(dispersion.per_sensor[2] == Approx(3.25).margin(5.0 * 3.25 * std::sqrt(2.0 / kTrucks)));
}

TEST_CASE("noise correlated along the array fails the autocorrelation check either sign", "[checks]") {
  for (double rho : {0.6, -0.6}) {
    INFO("neighbour correlation " << rho);
    const CheckReport report =
        discrepancy::run_checks(make_draws(7, rho), options_with(kReplicates, 7, 1e-3));
    check_found(check(report, CheckKind::kAutocorrelation), kReplicates);
  }
}

TEST_CASE("a second class of stiffer trucks fails the stiffness-distribution check only", "[checks]") {
  // 30 % of the trucks 10 sd above the rest (1000 against 500 ± 50 kN/m), compared with the
  // single normal that matches the whole fleet's mean and sd (what a fit of the base model
  // settles on). At 4 sd apart, 100 trucks give A² of only about 4 (p ≈ 0.01).
  boost::random::mt19937_64 classes(90);
  boost::random::uniform_01<double> uniform;
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const double mean = 0.3 * 10.0, sd = std::sqrt(1.0 + 0.3 * 0.7 * 100.0);
  PosteriorDraws draws = make_draws(9);
  draws.stiffness_pit = stiffness_pit_draws(9, [&](boost::random::mt19937_64& e) {
    const double k = (uniform(classes) < 0.3 ? 10.0 : 0.0) + normal(e);
    return (k - mean) / sd;
  });
  const CheckReport report = discrepancy::run_checks(draws, options_with(kReplicates, 9, 1e-3));
  check_found(check(report, CheckKind::kStiffnessDistribution), kReplicates);
  CHECK(report.gap.stiffness_distribution > 3.0);
  for (CheckKind kind : {CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kMass}) {
    check_not_found(check(report, kind));
  }
}

namespace {
// Each truck's standardised stiffness: `slope` times its covariate's standard score plus
// independent noise of the rest of the unit variance, compared with N(0, 1) as the fit would
// (the fleet's spread is right; only its dependence on the covariate is not in the model).
std::vector<Eigen::VectorXd> covariate_pit_draws(std::uint64_t seed, const Eigen::VectorXd& covariate, double slope) {
  const Eigen::ArrayXd x = covariate.array();
  const Eigen::ArrayXd score = (x - x.mean()) / std::sqrt((x - x.mean()).square().mean());
  Eigen::Index i = 0;
  return stiffness_pit_draws(seed, [&](boost::random::mt19937_64& e) {
    const double noise = boost::random::normal_distribution<double>(0.0, 1.0)(e);
    return slope * score[i++] + std::sqrt(1.0 - slope * slope) * noise;
  });
}
}  // namespace

TEST_CASE("tyre stiffness rising with speed fails the latent-covariate check, which names k_t and speed", "[checks]") {
  // Correlation 0.6 over 100 trucks: N c² ≈ 30 (less the PIT's bend), beyond every one of 4000
  // replicates of the largest of four χ²_1 (P(max > 20) ≈ 3e-5).
  PosteriorDraws draws = make_draws(11);
  draws.tyre_stiffness_pit = covariate_pit_draws(11 ^ 0x7474ULL, draws.speed_mps, 0.6);
  const CheckReport report = discrepancy::run_checks(draws, options_with(kReplicates, 11, 1e-3));
  const CheckResult& latent = check(report, CheckKind::kLatentCovariates);
  check_found(latent, kReplicates);
  CHECK_THAT(latent.detail, Catch::Contains("k_t against speed") && Catch::Contains("correlation +0."));
  // The residuals are the model's: no residual family sees it, and neither does the shape of k.
  for (CheckKind kind : {CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed, CheckKind::kMass,
                         CheckKind::kStiffnessDistribution}) {
    check_not_found(check(report, kind));
  }
}

TEST_CASE("suspension stiffness falling with load fails the latent-covariate check, naming k and sprung mass", "[checks]") {
  PosteriorDraws draws = make_draws(12);
  draws.stiffness_pit = covariate_pit_draws(12, draws.sprung_mass_kg, -0.6);
  const CheckReport report = discrepancy::run_checks(draws, options_with(kReplicates, 12, 1e-3));
  const CheckResult& latent = check(report, CheckKind::kLatentCovariates);
  check_found(latent, kReplicates);
  CHECK_THAT(latent.detail, Catch::Contains("k against sprung mass") && Catch::Contains("correlation -0."));
  check_not_found(check(report, CheckKind::kMass));
}

TEST_CASE("the latent-covariate family changes no other family's result and is vacuous without latents", "[checks]") {
  const PosteriorDraws with = make_draws(13);
  PosteriorDraws without = with;
  without.tyre_stiffness_pit.clear();
  const CheckOptions options = options_with(1000, 13);
  const CheckReport a = discrepancy::run_checks(with, options);
  const CheckReport b = discrepancy::run_checks(without, options);
  for (std::size_t k = 0; k < a.checks.size(); ++k) {
    if (a.checks[k].kind == CheckKind::kLatentCovariates) continue;
    INFO(fleet::check_name(a.checks[k].kind));
    CHECK(a.checks[k].p_value == b.checks[k].p_value);
    CHECK(a.checks[k].statistic == b.checks[k].statistic);
  }
  // With k alone the family still runs (its statistic is positive); with neither it is vacuous.
  CHECK(check(b, CheckKind::kLatentCovariates).statistic > 0.0);
  PosteriorDraws neither = without;
  neither.stiffness_pit.clear();
  const CheckReport vacuous = discrepancy::run_checks(neither, options);  // named: `none` must not outlive it
  const CheckResult& none = check(vacuous, CheckKind::kLatentCovariates);
  CHECK(none.statistic == 0.0);
  CHECK(none.p_value == 1.0);
  CHECK(none.detail.empty());
}

TEST_CASE("posterior checks reject inconsistent sizes naming the culprit", "[checks]") {
  const PosteriorDraws good = make_draws(8);
  const CheckOptions options = options_with(10, 1);
  const auto rejects = [&](PosteriorDraws draws, const std::string& culprit) {
    INFO("expected a complaint about " << culprit);
    CHECK_THROWS_AS(discrepancy::run_checks(draws, options), std::invalid_argument);
    CHECK_THROWS_WITH(discrepancy::run_checks(draws, options), Catch::Matchers::Contains(culprit));
  };
  {
    PosteriorDraws d = good;
    d.speed_mps.conservativeResize(kTrucks - 1);
    rejects(d, "speed_mps");
  }
  {
    PosteriorDraws d = good;
    d.sprung_mass_kg.conservativeResize(kTrucks + 1);
    rejects(d, "sprung_mass_kg");
  }
  {
    PosteriorDraws d = good;
    d.model_if[3].conservativeResize(kSensors - 1, kTrucks);
    rejects(d, "model_if[3]");
  }
  {
    PosteriorDraws d = good;
    d.lateral_m[5].conservativeResize(kTrucks - 2);
    rejects(d, "lateral_m[5]");
  }
  {
    PosteriorDraws d = good;
    d.lateral_m.pop_back();
    rejects(d, "lateral_m");
  }
  {
    PosteriorDraws d = good;
    d.sigma_if.push_back(kSigma);
    rejects(d, "sigma_if");
  }
  {
    PosteriorDraws d = good;
    d.sigma_if[0] = 0.0;
    rejects(d, "sigma_if[0]");
  }
  {
    PosteriorDraws d = good;
    d.stiffness_pit.pop_back();
    rejects(d, "stiffness_pit");
  }
  {
    PosteriorDraws d = good;
    d.stiffness_pit[2][4] = 1.5;
    rejects(d, "stiffness_pit[2]");
  }
  {
    PosteriorDraws d = good;
    d.tyre_stiffness_pit.pop_back();
    rejects(d, "tyre_stiffness_pit holds");
  }
  {
    PosteriorDraws d = good;
    d.tyre_stiffness_pit[6].conservativeResize(kTrucks - 1);
    rejects(d, "tyre_stiffness_pit[6]");
  }
  {
    PosteriorDraws d = good;
    d.model_if.clear();
    d.lateral_m.clear();
    d.sigma_if.clear();
    rejects(d, "model_if");
  }
  {
    // One truck: no spread across trucks to compare with.
    PosteriorDraws d = good;
    d.observed.conservativeResize(kSensors, 1);
    d.speed_mps.conservativeResize(1);
    d.sprung_mass_kg.conservativeResize(1);
    for (auto& f : d.model_if) f.conservativeResize(kSensors, 1);
    for (auto& z : d.lateral_m) z.conservativeResize(1);
    rejects(d, "trucks");
  }
  CHECK_THROWS_AS(discrepancy::run_checks(good, options_with(0, 1)), std::invalid_argument);
}
