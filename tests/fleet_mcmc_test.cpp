#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/math/special_functions/gamma.hpp>
#include <boost/random/mersenne_twister.hpp>
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include "fleet/batch_mcmc.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/truncated_samplers.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/effective_sample_size.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One-sample Kolmogorov-Smirnov statistic of draws against a CDF.
double ks_statistic(std::vector<double> draws, const std::function<double(double)>& cdf) {
  std::sort(draws.begin(), draws.end());
  const double n = static_cast<double>(draws.size());
  double d = 0.0;
  for (std::size_t i = 0; i < draws.size(); ++i) {
    const double f = cdf(draws[i]);
    d = std::max({d, std::abs(f - static_cast<double>(i) / n), std::abs(static_cast<double>(i + 1) / n - f)});
  }
  return d;
}

// The KS critical value at significance 0.001 (asymptotic: K = 1.9495).
double ks_critical_001(std::size_t n) { return 1.9495 / std::sqrt(static_cast<double>(n)); }

double upper_tail(double t) { return 0.5 * std::erfc(t / std::sqrt(2.0)); }

// CDF of N(mean, sd^2) truncated to [lo, hi], computed in the tail that keeps precision.
double truncated_normal_cdf(double x, double mean, double sd, double lo, double hi) {
  const double a = (lo - mean) / sd, b = (hi - mean) / sd, t = std::clamp((x - mean) / sd, a, b);
  if (a > 0.0) return (upper_tail(a) - upper_tail(t)) / (upper_tail(a) - upper_tail(b));
  return (upper_tail(-t) - upper_tail(-a)) / (upper_tail(-b) - upper_tail(-a));
}

double mean_of(const Eigen::VectorXd& v) { return v.mean(); }
double sd_of(const Eigen::VectorXd& v) {
  return std::sqrt((v.array() - v.mean()).square().sum() / static_cast<double>(v.size() - 1));
}

// Simulated data on AS1 (the paper's §4 set-up): Table 1 fleet, sigma_IF noise.
struct Simulated {
  std::vector<records::Truck> trucks;
  fleet::SimulatedLog log;
};
Simulated simulate(const site::Site& site, int trucks, double sigma_if, std::uint64_t seed) {
  Simulated s;
  s.trucks =
      fleet::draw_fleet(fleet::FleetDistribution{}, trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  s.log = fleet::simulate_log(site, s.trucks, sigma_if, seed);
  return s;
}

Eigen::MatrixXd true_latents(const std::vector<records::Truck>& trucks) {
  Eigen::MatrixXd x(static_cast<Eigen::Index>(trucks.size()), 3);
  for (std::size_t i = 0; i < trucks.size(); ++i) {
    const auto n = static_cast<Eigen::Index>(i);
    x(n, 0) = trucks[i].stiffness_npm;
    x(n, 1) = trucks[i].tyre_stiffness_npm;
    x(n, 2) = trucks[i].lateral_m;
  }
  return x;
}

}  // namespace

// ---- the exact samplers behind the Gibbs steps ----

TEST_CASE("truncated normal draws follow the truncated normal CDF (KS test at alpha 0.001)",
          "[fleet][mcmc][sampler]") {
  struct Case {
    double mean, sd, lo, hi;
    const char* what;
  };
  const Case cases[] = {{0.0, 1.0, -1.0, 2.0, "around the mean"},
                        {5e5, 5e4, 4e5, 4.2e5, "a K-like box below the mean"},
                        {0.0, 1.0, 3.0, 4.0, "upper tail by inversion"},
                        {0.0, 1.0, -5.0, -4.5, "lower tail by inversion"},
                        {0.0, 1.0, 10.0, kInf, "far upper tail, Marsaglia's method"},
                        {2.0, 0.5, -4.0, -2.5, "far lower tail, finite box"},
                        {0.0, 1.0, -kInf, kInf, "no truncation"}};
  boost::random::mt19937_64 engine(20240601);
  const std::size_t n = 20000;
  for (const Case& c : cases) {
    INFO(c.what);
    std::vector<double> draws(n);
    for (auto& d : draws) {
      d = fleet::draw_truncated_normal(engine, c.mean, c.sd, c.lo, c.hi);
      REQUIRE(d >= c.lo);
      REQUIRE(d <= c.hi);
    }
    const double d =
        ks_statistic(draws, [&](double x) { return truncated_normal_cdf(x, c.mean, c.sd, c.lo, c.hi); });
    INFO("KS D = " << d << ", critical " << ks_critical_001(n));
    CHECK(d < ks_critical_001(n));
  }
}

TEST_CASE("truncated gamma draws follow the truncated gamma CDF (KS test at alpha 0.001)",
          "[fleet][mcmc][sampler]") {
  struct Case {
    double shape, rate, lo, hi;
    const char* what;
  };
  const Case cases[] = {{14.5, 2.0, 0.0, kInf, "untruncated"},
                        {14.5, 2.0, 5.0, 8.0, "central box"},
                        {14.5, 2.0, 16.0, 18.0, "upper tail (gamma_q side)"},
                        {14.5, 2.0, 1.0, 2.5, "lower tail"},
                        {0.5, 3.0, 0.01, 1.0, "shape below one"},
                        {7.0, 0.0, 0.5, 3.0, "rate zero: a power law on the box"}};
  boost::random::mt19937_64 engine(77);
  const std::size_t n = 20000;
  for (const Case& c : cases) {
    INFO(c.what);
    std::vector<double> draws(n);
    for (auto& d : draws) {
      d = fleet::draw_truncated_gamma(engine, c.shape, c.rate, c.lo, c.hi);
      REQUIRE(d >= c.lo);
      REQUIRE(d <= c.hi);
    }
    std::function<double(double)> cdf;
    if (c.rate == 0.0) {
      cdf = [&](double x) {
        return (std::pow(x, c.shape) - std::pow(c.lo, c.shape)) /
               (std::pow(c.hi, c.shape) - std::pow(c.lo, c.shape));
      };
    } else {
      const double p_lo = boost::math::gamma_p(c.shape, c.rate * c.lo);
      const double p_hi = std::isfinite(c.hi) ? boost::math::gamma_p(c.shape, c.rate * c.hi) : 1.0;
      cdf = [=](double x) { return (boost::math::gamma_p(c.shape, c.rate * x) - p_lo) / (p_hi - p_lo); };
    }
    const double d = ks_statistic(draws, cdf);
    INFO("KS D = " << d << ", critical " << ks_critical_001(n));
    CHECK(d < ks_critical_001(n));
  }
}

TEST_CASE("a truncated gamma box whose mass underflows is still sampled exactly (tangent rejection)",
          "[fleet][mcmc][sampler]") {
  // Gamma(50, 1) on [1000, 1003]: the upper tail there is ~e^-1000, far below the smallest
  // double. The CDF on the box, by quadrature of the density rescaled at the box's start.
  const double shape = 50.0, rate = 1.0, lo = 1000.0, hi = 1003.0;
  CHECK_THROWS_AS(fleet::truncated_gamma_quantile(0.5, shape, rate, lo, hi), NumericalError);
  auto g = [&](double t) { return std::exp((shape - 1.0) * std::log(t / lo) - rate * (t - lo)); };
  const double total = boost::math::quadrature::gauss_kronrod<double, 61>::integrate(g, lo, hi, 15, 1e-13);
  boost::random::mt19937_64 engine(3);
  const std::size_t n = 20000;
  std::vector<double> draws(n);
  for (auto& d : draws) d = fleet::draw_truncated_gamma(engine, shape, rate, lo, hi);
  const double d = ks_statistic(draws, [&](double x) {
    return boost::math::quadrature::gauss_kronrod<double, 31>::integrate(g, lo, x, 0, 1e-12) / total;
  });
  INFO("KS D = " << d);
  CHECK(d < ks_critical_001(n));
}

TEST_CASE("sigma drawn from a sum of squares has the uniform-prior conditional (KS test at alpha 0.001)",
          "[fleet][mcmc][sampler]") {
  // p(sigma | S) proportional to sigma^-n exp(-S / (2 sigma^2)) on the box: integrate it.
  const int n_obs = 30;
  const double ss = 30 * 50e3 * 50e3, lo = 1e3, hi = 5e5;
  auto density = [&](double s) {
    const double s0 = std::sqrt(ss / n_obs);  // the mode, for scaling
    return std::exp(-n_obs * std::log(s / s0) - 0.5 * ss / (s * s) + 0.5 * ss / (s0 * s0));
  };
  const double total =
      boost::math::quadrature::gauss_kronrod<double, 61>::integrate(density, lo, hi, 20, 1e-13);
  boost::random::mt19937_64 engine(9);
  const std::size_t n = 20000;
  std::vector<double> draws(n);
  for (auto& d : draws) d = fleet::draw_scale_given_sum_squares(engine, n_obs, ss, lo, hi);
  const double d = ks_statistic(draws, [&](double x) {
    return boost::math::quadrature::gauss_kronrod<double, 61>::integrate(density, lo, x, 15, 1e-12) / total;
  });
  INFO("KS D = " << d);
  CHECK(d < ks_critical_001(n));
  CHECK_THROWS_AS(fleet::draw_scale_given_sum_squares(engine, 1, ss, lo, hi), std::invalid_argument);
}

// ---- summaries ----

TEST_CASE(
    "posterior summaries give Hazen quantiles for equal weights and match duplication for integer weights",
    "[fleet][summary]") {
  Eigen::MatrixXd draws(4, 1);
  draws << 3.0, 1.0, 4.0, 2.0;
  const auto s = fleet::summarize_draws(draws);
  CHECK(s[0].mean == Approx(2.5));
  CHECK(s[0].sd == Approx(std::sqrt(5.0 / 3.0)));
  // Hazen positions (i - 1/2) / 4 = 0.125, 0.375, ...: 0.025 is below the first point.
  CHECK(s[0].q025 == 1.0);
  CHECK(s[0].q975 == 4.0);
  CHECK(fleet::weighted_quantile(draws.col(0), Eigen::VectorXd::Ones(4), 0.5) == Approx(2.5));
  CHECK(fleet::weighted_quantile(draws.col(0), Eigen::VectorXd::Ones(4), 0.25) == Approx(1.5));

  // Weights 2,1,1,3 on values 1,2,3,4 against the duplicated sample 1,1,2,3,4,4,4.
  Eigen::VectorXd values(4), weights(4), duplicated(7);
  values << 1, 2, 3, 4;
  weights << 2, 1, 1, 3;
  duplicated << 1, 1, 2, 3, 4, 4, 4;
  const Eigen::MatrixXd as_matrix = values;
  const auto w = fleet::summarize_draws(as_matrix, &weights);
  CHECK(w[0].mean == Approx(duplicated.mean()));
  CHECK(fleet::weighted_quantile(values, weights, 0.5) == Approx(3.0));
  CHECK_THROWS_AS(fleet::weighted_quantile(values, Eigen::VectorXd::Zero(4), 0.5), std::invalid_argument);
}

TEST_CASE("weighted quantiles of a large equally weighted normal sample match the normal quantiles",
          "[fleet][summary]") {
  boost::random::mt19937_64 engine(1);
  const int n = 40000;
  Eigen::MatrixXd draws(n, 1);
  for (int i = 0; i < n; ++i) draws(i, 0) = fleet::draw_truncated_normal(engine, 1.0, 2.0, -kInf, kInf);
  // Random weights do not change the target when the draws are iid from it.
  Eigen::VectorXd weights(n);
  for (int i = 0; i < n; ++i) weights[i] = 0.5 + fleet::uniform_open01(engine);
  const auto s = fleet::summarize_draws(draws, &weights);
  // sd of a sample 2.5 % quantile ~ sqrt(p(1-p)/n) / phi(1.96) * 2 = 0.027; allow 4 sd.
  CHECK(s[0].mean == Approx(1.0).margin(0.05));
  CHECK(s[0].sd == Approx(2.0).margin(0.05));
  CHECK(s[0].q025 == Approx(1.0 - 1.959964 * 2.0).margin(0.12));
  CHECK(s[0].q975 == Approx(1.0 + 1.959964 * 2.0).margin(0.12));
}

// ---- options ----

TEST_CASE("bad batch MCMC options are rejected with a message naming the option", "[fleet][mcmc]") {
  struct Case {
    std::function<void(fleet::BatchMcmcOptions&)> change;
    const char* name;
  };
  const Case cases[] = {
      {[](auto& o) { o.iterations = 0; }, "iterations"},
      {[](auto& o) { o.burn_in = o.iterations; }, "burn_in"},
      {[](auto& o) { o.burn_in = -1; }, "burn_in"},
      {[](auto& o) { o.thin = 0; }, "thin"},
      {[](auto& o) { o.target_acceptance = 1.0; }, "target_acceptance"},
      {[](auto& o) { o.z_moves_per_sweep = 0; }, "z_moves_per_sweep"},
      {[](auto& o) { o.init_grid_step_m = 0.0; }, "init_grid_step_m"},
      {[](auto& o) { o.hold_theta_sweeps = -1; }, "hold_theta_sweeps"},
      {[](auto& o) { o.progress_every = -5; }, "progress_every"},
      {[](auto& o) { o.prior.lo[fleet::kSigmaK] = o.prior.hi[fleet::kSigmaK]; }, "sigma_k"},
      {[](auto& o) { o.freeze_latents = true; }, "freeze_latents"},
      {[](auto& o) { o.initial_theta = fleet::HyperVector{}; }, "initial_theta"},
      {[](auto& o) { o.ancillary_steps = 0; }, "ancillary_steps"},
      {[](auto& o) { o.ancillary_every = 0; }, "ancillary_every"},
      {[](auto& o) { o.threads = -1; }, "threads"},
  };
  fleet::BatchMcmcOptions good;
  std::string error;
  CHECK(good.IsValid(&error));
  for (const Case& c : cases) {
    fleet::BatchMcmcOptions o;
    c.change(o);
    std::string message;
    INFO("option " << c.name);
    CHECK_FALSE(o.IsValid(&message));
    CHECK_THAT(message, Catch::Contains(c.name));
    CHECK_FALSE(o.IsValid(nullptr));
  }
}

TEST_CASE("run_batch_mcmc refuses bad options and mismatched records before simulating", "[fleet][mcmc]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  fleet::BatchMcmcOptions o;
  o.iterations = 0;
  std::vector<records::WimRecord> records(1);
  records[0].truck_id = "T1";
  records[0].speed_mps = 20.0;
  records[0].sprung_mass_kg = 4000.0;
  records[0].impact_factor = Eigen::VectorXd::Ones(5);  // the site has 16 sensors
  CHECK_THROWS_AS(fleet::run_batch_mcmc(site, records, o), UsageError);
  o.iterations = 10;
  o.burn_in = 5;
  CHECK_THROWS_AS(fleet::run_batch_mcmc(site, records, o), DataError);
  CHECK_THROWS_AS(fleet::run_batch_mcmc(site, {}, o), DataError);
}

// ---- posterior correctness where the answer is known ----

TEST_CASE("with latents frozen the hyperparameter draws follow their analytic conditional posterior",
          "[fleet][mcmc]") {
  // With k_n fixed and uniform priors (box wide enough to be irrelevant), integrating sigma_k out
  // gives K | k ~ k_bar + sqrt(S0 / (N (N-2))) t_{N-2}: mean k_bar, sd sqrt(S0 / (N (N-4))); and
  // 1/sigma_k^2 | k ~ Gamma((N-2)/2, S0/2): E sigma_k^2 = S0 / (N-4). sigma_IF has its own exact
  // conditional, Gamma((NM-1)/2, S/2) for the precision. (Z, sigma_z) go through MH: compare
  // with 2-D quadrature of their posterior.
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const int N = 30;
  const Simulated sim = simulate(site, N, 0.02, 4242);
  const Eigen::MatrixXd x = true_latents(sim.trucks);

  fleet::BatchMcmcOptions o;
  o.iterations = 40000;
  o.burn_in = 1000;
  o.hold_theta_sweeps = 0;
  o.seed = 17;
  o.initial_latents = x;
  o.freeze_latents = true;
  const auto r = fleet::run_batch_mcmc(site, sim.log.records, o);
  CHECK(r.integrator_calls == 1);  // the residuals once, never again
  CHECK(r.theta_draws.rows() == 39000);

  auto check_moment = [](const char* what, const Eigen::VectorXd& draws, double expected_mean,
                         double expected_sd) {
    const double ess = chain_effective_sample_size(draws);
    const double mc_error = expected_sd / std::sqrt(ess);
    INFO(what << ": mean " << mean_of(draws) << " vs " << expected_mean << " (MC error " << mc_error
              << ", ESS " << ess << "), sd " << sd_of(draws) << " vs " << expected_sd);
    CHECK(std::abs(mean_of(draws) - expected_mean) < 4.0 * mc_error);
    // The sd of a sample sd is about sd / sqrt(2 ESS) for near-normal draws; allow 5 of those
    // (the t tails make it wider).
    CHECK(std::abs(sd_of(draws) - expected_sd) < 5.0 * expected_sd / std::sqrt(2.0 * ess));
  };

  for (const auto& [mean_i, sd_i, col] :
       {std::tuple{fleet::kK, fleet::kSigmaK, 0}, std::tuple{fleet::kKt, fleet::kSigmaKt, 1}}) {
    const Eigen::VectorXd v = x.col(col);
    const double kbar = v.mean(), s0 = (v.array() - kbar).square().sum();
    check_moment(std::string(fleet::kHyperNames[mean_i]).c_str(), r.theta_draws.col(mean_i), kbar,
                 std::sqrt(s0 / (N * (N - 4.0))));
    const Eigen::VectorXd var = r.theta_draws.col(sd_i).array().square();
    // Var of 1/tau for tau ~ Gamma(a, b): b^2 / ((a-1)^2 (a-2)).
    const double a = 0.5 * (N - 2), b = 0.5 * s0;
    check_moment((std::string(fleet::kHyperNames[sd_i]) + "^2").c_str(), var, b / (a - 1.0),
                 b / ((a - 1.0) * std::sqrt(a - 2.0)));
  }

  // sigma_IF: the total SSR at the true latents, N M observations.
  const double S = (sim.log.model_if -
                    [&] {
                      Eigen::ArrayXXd y(site.sensors(), N);
                      for (int n = 0; n < N; ++n)
                        y.col(n) = sim.log.records[static_cast<std::size_t>(n)].impact_factor.array();
                      return y;
                    }())
                       .square()
                       .sum();
  {
    const double a = 0.5 * (N * site.sensors() - 2.0),
                 b = 0.5 * S;  // sigma^2 = 1/tau, tau ~ Gamma(a + 1/2, b)
    const Eigen::VectorXd var = r.theta_draws.col(fleet::kSigmaIf).array().square();
    const double a_tau = a + 0.5;
    check_moment("sigma_if^2", var, b / (a_tau - 1.0), b / ((a_tau - 1.0) * std::sqrt(a_tau - 2.0)));
  }

  // (Z, sigma_z): posterior proportional to prod_n N_trunc(z_n; Z, sigma_z) on the prior box.
  {
    const fleet::PriorBounds prior;
    const Eigen::VectorXd z = x.col(2);
    auto log_post = [&](double Z, double sz) {
      double lp = 0.0;
      for (int n = 0; n < N; ++n) lp += fleet::log_normal_density(z[n], Z, sz);
      return lp - N * fleet::log_normal_mass(site.lateral_min_m(), site.lateral_max_m(), Z, sz);
    };
    // Riemann sum on a fine grid around the mass (the posterior is well inside the box).
    const int G = 400;
    const double z_lo = 0.8, z_hi = 2.4, s_lo = 0.2, s_hi = 1.2;
    double peak = -kInf;
    std::vector<double> lp(static_cast<std::size_t>(G * G));
    for (int i = 0; i < G; ++i)
      for (int j = 0; j < G; ++j) {
        const double Z = z_lo + (i + 0.5) * (z_hi - z_lo) / G, sz = s_lo + (j + 0.5) * (s_hi - s_lo) / G;
        lp[static_cast<std::size_t>(i * G + j)] = log_post(Z, sz);
        peak = std::max(peak, lp[static_cast<std::size_t>(i * G + j)]);
      }
    double w = 0.0, mz = 0.0, mz2 = 0.0, ms = 0.0, ms2 = 0.0;
    for (int i = 0; i < G; ++i)
      for (int j = 0; j < G; ++j) {
        const double Z = z_lo + (i + 0.5) * (z_hi - z_lo) / G, sz = s_lo + (j + 0.5) * (s_hi - s_lo) / G;
        const double p = std::exp(lp[static_cast<std::size_t>(i * G + j)] - peak);
        w += p;
        mz += p * Z;
        mz2 += p * Z * Z;
        ms += p * sz;
        ms2 += p * sz * sz;
      }
    mz /= w;
    ms /= w;
    check_moment("Z", r.theta_draws.col(fleet::kZ), mz, std::sqrt(mz2 / w - mz * mz));
    check_moment("sigma_z", r.theta_draws.col(fleet::kSigmaZ), ms, std::sqrt(ms2 / w - ms * ms));
    CHECK(r.z_acceptance > 0.15);
    CHECK(r.z_acceptance < 0.5);
  }
}

namespace {
void check_credible_intervals(const fleet::BatchMcmcResult& r, double sigma_if) {
  const auto s = fleet::summarize_draws(r.theta_draws);
  const fleet::FleetDistribution truth;
  const std::pair<int, double> checks[] = {{fleet::kK, truth.stiffness_npm.mean},
                                           {fleet::kKt, truth.tyre_stiffness_npm.mean},
                                           {fleet::kZ, truth.lateral_m.mean},
                                           {fleet::kSigmaIf, sigma_if}};
  for (const auto& [j, value] : checks) {
    const auto& p = s[static_cast<std::size_t>(j)];
    INFO(fleet::kHyperNames[j] << ": truth " << value << ", posterior mean " << p.mean << " sd " << p.sd
                               << ", 95 % [" << p.q025 << ", " << p.q975 << "], ESS "
                               << chain_effective_sample_size(r.theta_draws.col(j)));
    CHECK(p.q025 <= value);
    CHECK(value <= p.q975);
  }
}
}  // namespace

TEST_CASE("batch MCMC on 30 simulated trucks brackets the true K and Kt and Z and sigma_IF",
          "[fleet][mcmc]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const Simulated sim = simulate(site, 30, 0.02, 101);
  fleet::BatchMcmcOptions o;
  o.iterations = 6000;
  o.burn_in = 2000;
  o.seed = 5;
  int reports = 0;
  o.progress_every = 1000;
  o.progress = [&](const fleet::BatchMcmcProgress& p) {
    ++reports;
    CHECK(p.iteration == 1000 * reports);
  };
  const auto r = fleet::run_batch_mcmc(site, sim.log.records, o);
  CHECK(reports == 6);
  REQUIRE(r.theta_draws.rows() == 4000);
  INFO("latent acceptance " << r.latent_acceptance << ", (Z, sigma_z) acceptance " << r.z_acceptance
                            << ", wall " << r.wall_seconds << " s");
  // Adapted towards 0.3 and frozen: the post-burn-in rate lands near it.
  CHECK(r.latent_acceptance > 0.15);
  CHECK(r.latent_acceptance < 0.5);
  // One batched pass per sweep plus the grid search (51 lateral positions per truck), plus one per
  // lateral-jump sweep, at most one per joint-jump sweep and one per ancillary step of each
  // interwoven block once theta is free.
  const long long interwoven_blocks =
      o.interweave
          ? int{o.interweave_stiffness} + int{o.interweave_tyre_stiffness} + int{o.interweave_lateral}
          : 0;
  CHECK(r.integrator_passes <= 30LL * 51 + 30LL * 6000 + 30LL * ((6000 + o.lateral_jump_every - 1) / o.lateral_jump_every) +
                                   30LL * ((6000 + o.joint_jump_every - 1) / o.joint_jump_every) +
                                   interwoven_blocks * o.ancillary_steps * 30LL *
                                       ((6000 - o.hold_theta_sweeps) / o.ancillary_every + 1));
  CHECK(r.integrator_calls >= 6000);
  check_credible_intervals(r, 0.02);
  // Truck lateral positions: the posterior means track the truth for most trucks.
  const Eigen::MatrixXd x = true_latents(sim.trucks);
  int close = 0;
  for (int n = 0; n < 30; ++n)
    close += std::abs(r.latent_mean(n, 2) - x(n, 2)) < 3.0 * r.latent_sd(n, 2) + 0.05;
  INFO(close << " of 30 lateral positions within 3 sd");
  CHECK(close >= 25);
}

TEST_CASE("batch MCMC is reproducible from its seed", "[fleet][mcmc]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const Simulated sim = simulate(site, 5, 0.02, 7);
  fleet::BatchMcmcOptions o;
  o.iterations = 60;
  o.burn_in = 20;
  o.hold_theta_sweeps = 10;
  o.seed = 99;
  const auto a = fleet::run_batch_mcmc(site, sim.log.records, o);
  const auto b = fleet::run_batch_mcmc(site, sim.log.records, o);
  CHECK(a.theta_draws == b.theta_draws);
  CHECK(a.latent_mean == b.latent_mean);
  o.seed = 100;
  const auto c = fleet::run_batch_mcmc(site, sim.log.records, o);
  CHECK(a.theta_draws != c.theta_draws);
}

TEST_CASE("batch MCMC on the paper's 100-truck case brackets the true hyperparameters",
          "[fleet][mcmc][long]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const Simulated sim = simulate(site, 100, 0.02, 2009);
  fleet::BatchMcmcOptions o;
  o.iterations = 20000;
  o.burn_in = 5000;
  o.seed = 11;
  const auto r = fleet::run_batch_mcmc(site, sim.log.records, o);
  INFO("wall " << r.wall_seconds << " s, " << r.iterations / r.wall_seconds << " sweeps/s, "
               << r.integrator_passes / r.wall_seconds << " passes/s, latent acceptance "
               << r.latent_acceptance);
  CHECK(r.latent_acceptance > 0.15);
  CHECK(r.latent_acceptance < 0.5);
  check_credible_intervals(r, 0.02);
  const auto s = fleet::summarize_draws(r.theta_draws);
  CHECK(s[fleet::kSigmaZ].q025 <= 0.5);
  CHECK(0.5 <= s[fleet::kSigmaZ].q975);
}

TEST_CASE("lateral jumps let the batch MCMC cross between lateral modes on AS2", "[mcmc][heavy]") {
  // A fleet on road AS2 whose trucks' z-likelihoods are broad and many-peaked across the lane: the
  // random walk on (k, k_t, z) stays in the peak each truck starts in (its best fit), and sigma_z
  // stays where those starts put it.
  const site::Site site(site::load_road("AS2"), site::SiteOptions{});
  const auto trucks = fleet::draw_fleet(test::second_fleet(), 200, site.lateral_min_m(), site.lateral_max_m(), 1);
  const auto log = fleet::simulate_log(site, trucks, 0.03, 1);
  auto sigma_z = [&](int jump_every) {
    fleet::BatchMcmcOptions o;
    o.iterations = 4000;
    o.burn_in = 1000;
    o.seed = 7;
    o.threads = 2;
    o.lateral_jump_every = jump_every;
    o.joint_jump_every = 0;  // the joint jumps cross lateral modes too: this test is about the lateral ones
    const auto r = fleet::run_batch_mcmc(site, log.records, o);
    const Eigen::VectorXd c = r.theta_draws.col(fleet::kSigmaZ);
    const double mean = c.mean(), sd = std::sqrt((c.array() - mean).square().mean());
    struct Out {
      double mean, sd, ess, jump_acceptance;
    };
    return Out{mean, sd, chain_effective_sample_size(c), r.lateral_jump_acceptance};
  };
  const auto with = sigma_z(fleet::BatchMcmcOptions{}.lateral_jump_every);
  const auto without = sigma_z(0);
  INFO("with jumps: sigma_z " << with.mean << " +- " << with.sd << ", ESS " << with.ess << ", jump acceptance "
                              << with.jump_acceptance << "; without: " << without.mean << " +- " << without.sd
                              << ", ESS " << without.ess);
  CHECK(fleet::BatchMcmcOptions{}.lateral_jump_every > 0);  // on by default
  CHECK(with.jump_acceptance > 0.1);
  // With jumps the truth (0.35) is within 3 posterior sd, allowing 4 Monte Carlo sd of the mean.
  CHECK(std::abs(with.mean - 0.35) < 3.0 * with.sd + 4.0 * with.sd / std::sqrt(with.ess));
  CHECK(with.ess > 100.0);
  // Without them the chain is stuck far off: the trap is real, so the check above means something.
  CHECK(std::abs(without.mean - 0.35) > 3.0 * without.sd);
}
