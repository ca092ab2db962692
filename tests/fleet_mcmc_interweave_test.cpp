// The batch MCMC's interweaving (ancillary) kernel and its thread split (batch_mcmc_interweave.hpp,
// batch_mcmc.hpp).
//
// The ancillary kernel is checked on a model whose posterior is known: a fake likelihood
// y_n ~ N(x_n, s^2) in place of the quarter car (the kernel sees the likelihood only through the
// per-truck sums of squared residuals it asks for), x_n ~ N(M, S^2) (truncated to the road for
// the lateral block). A chain alternating an exact Gibbs draw of x_1..N given (M, S, y) with the
// ancillary step alone (no centred step) targets p(M, S, x | y) only if the ancillary step leaves
// it invariant; its (M, S) draws are compared with the marginal posterior p(M, S | y), by 2-D
// quadrature, within Monte Carlo error from the draws' ESS. A wrong Jacobian (of the log-scale walk)
// or a missing truncation normaliser shifts sigma by many Monte Carlo errors here.
#include <cmath>
#include <string>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <catch2/catch.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_interweave.hpp"
#include "model/fleet_distribution.hpp"
#include "fleet/simulator.hpp"
#include "model/truncated_samplers.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;

namespace {

struct Moments {
  double mean = 0.0, sd = 0.0;
};

// Mean and sd of M and S under the density exp(log_post(M, S)) on the box, by the midpoint rule.
std::pair<Moments, Moments> quadrature_moments(const std::function<double(double, double)>& log_post,
                                               double m_lo, double m_hi, double s_lo, double s_hi, int grid) {
  std::vector<double> lp(static_cast<std::size_t>(grid * grid));
  double peak = -std::numeric_limits<double>::infinity();
  auto at = [&](int i, int j) {
    return std::pair{m_lo + (i + 0.5) * (m_hi - m_lo) / grid, s_lo + (j + 0.5) * (s_hi - s_lo) / grid};
  };
  for (int i = 0; i < grid; ++i)
    for (int j = 0; j < grid; ++j) {
      const auto [m, s] = at(i, j);
      lp[static_cast<std::size_t>(i * grid + j)] = log_post(m, s);
      peak = std::max(peak, lp[static_cast<std::size_t>(i * grid + j)]);
    }
  double w = 0, m1 = 0, m2 = 0, s1 = 0, s2 = 0;
  for (int i = 0; i < grid; ++i)
    for (int j = 0; j < grid; ++j) {
      const auto [m, s] = at(i, j);
      const double p = std::exp(lp[static_cast<std::size_t>(i * grid + j)] - peak);
      w += p;
      m1 += p * m;
      m2 += p * m * m;
      s1 += p * s;
      s2 += p * s * s;
    }
  m1 /= w;
  s1 /= w;
  return {{m1, std::sqrt(m2 / w - m1 * m1)}, {s1, std::sqrt(s2 / w - s1 * s1)}};
}

void check_draws(const char* what, const Eigen::VectorXd& draws, const Moments& expected) {
  const double ess = chain_effective_sample_size(draws);
  const double mean = draws.mean();
  const double sd = std::sqrt((draws.array() - mean).square().sum() / static_cast<double>(draws.size() - 1));
  const double mc_error = expected.sd / std::sqrt(ess);
  INFO(what << ": mean " << mean << " vs " << expected.mean << " (MC error " << mc_error << ", ESS " << ess
            << "), sd " << sd << " vs " << expected.sd);
  REQUIRE(ess > 500.0);  // enough draws for the normal approximations below
  CHECK(std::abs(mean - expected.mean) < 4.5 * mc_error);
  // The sd of a sample sd is about sd / sqrt(2 ESS) for near-normal draws; allow 5 of them.
  CHECK(std::abs(sd - expected.sd) < 5.0 * expected.sd / std::sqrt(2.0 * ess));
}

// Runs Gibbs-for-x + ancillary-only for `sweeps` (the first fifth adapts and is dropped) and
// returns the (M, S) draws. draw_x(engine, theta, x) is the exact conditional of the latents.
Eigen::MatrixXd run_fake_chain(fleet::AncillaryUpdater& updater, fleet::Hyper mean_index,
                               fleet::Hyper sd_index, const Eigen::ArrayXd& y, double noise_sd,
                               fleet::HyperVector theta, const fleet::PriorBounds& prior,
                               const fleet::LateralRange& range, int sweeps,
                               const std::function<void(boost::random::mt19937_64&, const fleet::HyperVector&,
                                                        Eigen::ArrayXd&)>& draw_x) {
  boost::random::mt19937_64 engine(2011);
  const auto N = y.size();
  Eigen::ArrayXd x(N), ssr(N);
  const fleet::AncillarySsrFunction fake_ssr = [&](const Eigen::ArrayXd& values, Eigen::ArrayXd& out) {
    out = (values - y).square();
  };
  const double inv2var = 0.5 / (noise_sd * noise_sd);
  const int burn_in = sweeps / 5;
  Eigen::MatrixXd draws(sweeps - burn_in, 2);
  for (int it = 0; it < sweeps; ++it) {
    draw_x(engine, theta, x);
    fake_ssr(x, ssr);
    const bool adapt = it < burn_in;
    updater.step(engine, theta, x, ssr, inv2var, fake_ssr, prior, range, 0.3, adapt,
                 adapt && it > burn_in / 4);
    // The ancillary step keeps ssr in step with x.
    if (it % 1000 == 0) REQUIRE(((x - y).square() - ssr).abs().maxCoeff() < 1e-9);
    if (!adapt) {
      draws(it - burn_in, 0) = theta[static_cast<std::size_t>(mean_index)];
      draws(it - burn_in, 1) = theta[static_cast<std::size_t>(sd_index)];
    }
  }
  INFO("ancillary acceptance " << static_cast<double>(updater.accepted()) /
                                      static_cast<double>(updater.tried()));
  CHECK(updater.accepted() > updater.tried() / 10);
  return draws;
}

}  // namespace

TEST_CASE("the ancillary (K, sigma_k) step leaves the posterior of a Gaussian fake model invariant",
          "[fleet][mcmc][interweave]") {
  // 8 trucks, y_n ~ N(k_n, 1), k_n ~ N(K, sigma_k^2); box K in [20, 40], sigma_k in [0.2, 4] (k > 0
  // then has probability 1 - 1e-6 or more, so the kernel's support check does not bind).
  const Eigen::ArrayXd y = (Eigen::ArrayXd(8) << 29.1, 31.4, 30.2, 27.9, 32.6, 30.8, 28.7, 33.0).finished();
  const double s = 1.0;
  fleet::PriorBounds prior;
  prior.lo[fleet::kK] = 20.0;
  prior.hi[fleet::kK] = 40.0;
  prior.lo[fleet::kSigmaK] = 0.2;
  prior.hi[fleet::kSigmaK] = 4.0;
  const fleet::LateralRange range;
  // p(K, sigma_k | y) on the box: prod_n N(y_n; K, sigma_k^2 + s^2).
  const auto [expected_K, expected_sk] = quadrature_moments(
      [&](double K, double sk) {
        double lp = 0.0;
        for (double v : y) lp += fleet::log_normal_density(v, K, std::sqrt(sk * sk + s * s));
        return lp;
      },
      prior.lo[fleet::kK], prior.hi[fleet::kK], prior.lo[fleet::kSigmaK], prior.hi[fleet::kSigmaK], 600);

  fleet::HyperVector theta = prior.lo;
  theta[fleet::kK] = 30.0;
  theta[fleet::kSigmaK] = 1.0;
  fleet::AncillaryUpdater updater(fleet::kK, fleet::kSigmaK, false, 8);
  const Eigen::MatrixXd draws =
      run_fake_chain(updater, fleet::kK, fleet::kSigmaK, y, s, theta, prior, range, 250000,
                     [&](boost::random::mt19937_64& engine, const fleet::HyperVector& t, Eigen::ArrayXd& x) {
                       // k_n | K, sigma_k, y_n: normal, precisions add.
                       const double K = t[fleet::kK], sk = t[fleet::kSigmaK];
                       const double var = 1.0 / (1.0 / (sk * sk) + 1.0 / (s * s));
                       boost::random::normal_distribution<double> normal(0.0, 1.0);
                       for (Eigen::Index n = 0; n < x.size(); ++n)
                         x[n] = var * (K / (sk * sk) + y[n] / (s * s)) + std::sqrt(var) * normal(engine);
                     });
  check_draws("K", draws.col(0), expected_K);
  check_draws("sigma_k", draws.col(1), expected_sk);
}

TEST_CASE("the ancillary (Z, sigma_z) step leaves the posterior of a truncated fake model invariant",
          "[fleet][mcmc][interweave]") {
  // 8 trucks on a 3 m road, y_n ~ N(z_n, 1), z_n ~ N(Z, sigma_z^2) truncated to [0, 3]; the
  // box lets sigma_z reach the road's width, so the truncation normaliser matters.
  const Eigen::ArrayXd y = (Eigen::ArrayXd(8) << 0.4, 1.9, 2.6, 1.1, 0.2, 2.2, 1.5, 2.9).finished();
  const double s = 1.0;  // weak data: the regime where the ancillary step alone mixes well
  const fleet::LateralRange range{0.0, 3.0};
  fleet::PriorBounds prior;
  prior.lo[fleet::kZ] = 0.0;
  prior.hi[fleet::kZ] = 3.0;
  prior.lo[fleet::kSigmaZ] = 0.1;
  prior.hi[fleet::kSigmaZ] = 3.0;
  // p(Z, sigma_z | y) on the box: prod_n N(y_n; Z, sigma_z^2 + s^2) P_n / P(Z, sigma_z), P_n the
  // mass on the road of z_n's posterior given y_n (untruncated), P(Z, sigma_z) the prior's.
  const auto [expected_Z, expected_sz] = quadrature_moments(
      [&](double Z, double sz) {
        const double var = 1.0 / (1.0 / (sz * sz) + 1.0 / (s * s));
        double lp = 0.0;
        for (double v : y) {
          lp += fleet::log_normal_density(v, Z, std::sqrt(sz * sz + s * s));
          lp += fleet::log_normal_mass(range.lo_m, range.hi_m, var * (Z / (sz * sz) + v / (s * s)),
                                       std::sqrt(var));
        }
        return lp - static_cast<double>(y.size()) * fleet::log_normal_mass(range.lo_m, range.hi_m, Z, sz);
      },
      prior.lo[fleet::kZ], prior.hi[fleet::kZ], prior.lo[fleet::kSigmaZ], prior.hi[fleet::kSigmaZ], 600);

  fleet::HyperVector theta = prior.lo;
  theta[fleet::kZ] = 1.5;
  theta[fleet::kSigmaZ] = 1.0;
  fleet::AncillaryUpdater updater(fleet::kZ, fleet::kSigmaZ, true, 8);
  const Eigen::MatrixXd draws =
      run_fake_chain(updater, fleet::kZ, fleet::kSigmaZ, y, s, theta, prior, range, 1000000,
                     [&](boost::random::mt19937_64& engine, const fleet::HyperVector& t, Eigen::ArrayXd& x) {
                       const double Z = t[fleet::kZ], sz = t[fleet::kSigmaZ];
                       const double var = 1.0 / (1.0 / (sz * sz) + 1.0 / (s * s));
                       for (Eigen::Index n = 0; n < x.size(); ++n)
                         x[n] = fleet::draw_truncated_normal(engine, var * (Z / (sz * sz) + y[n] / (s * s)),
                                                             std::sqrt(var), range.lo_m, range.hi_m);
                     });
  check_draws("Z", draws.col(0), expected_Z);
  check_draws("sigma_z", draws.col(1), expected_sz);
}

TEST_CASE("batch MCMC draws are bit-identical at 1 and 2 threads, interweaving on and off",
          "[fleet][mcmc][interweave]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  // 40 trucks: three integrator blocks (16, 16, 8), split unevenly over 2 threads.
  const auto trucks =
      fleet::draw_fleet(fleet::FleetDistribution{}, 40, site.lateral_min_m(), site.lateral_max_m(), 31);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 31);
  for (const bool interweave : {false, true}) {
    INFO("interweave " << interweave);
    fleet::BatchMcmcOptions o;
    o.iterations = 300;
    o.burn_in = 100;
    o.hold_theta_sweeps = 20;
    o.seed = 5;
    o.interweave = interweave;  // every block, to cover all three
    o.interweave_stiffness = o.interweave_tyre_stiffness = o.interweave_lateral = true;
    o.threads = 1;
    const auto one = fleet::run_batch_mcmc(site, log.records, o);
    o.threads = 2;
    const auto two = fleet::run_batch_mcmc(site, log.records, o);
    CHECK(one.threads == 1);
    CHECK(two.threads == 2);
    CHECK(one.theta_draws == two.theta_draws);
    CHECK(one.log_target == two.log_target);
    CHECK(one.latent_mean == two.latent_mean);
    CHECK(one.latent_sd == two.latent_sd);
    CHECK(one.integrator_passes == two.integrator_passes);
    // Interweaving re-simulates all 40 trucks per ancillary step: 3 blocks x 1 step per sweep
    // once theta is free.
    const long long ancillary = interweave ? 3LL * 40 * (300 - 20) : 0;
    // Lateral jumps: all 40 trucks on every lateral_jump_every-th sweep; joint jumps: at most all 40
    // (a proposal with k or k_t <= 0 is not simulated) on every joint_jump_every-th.
    const long long jumps = 40LL * ((300 + o.lateral_jump_every - 1) / o.lateral_jump_every) +
                            40LL * ((300 + o.joint_jump_every - 1) / o.joint_jump_every);
    CHECK(one.integrator_passes <= 40LL * 51 + 40LL * 300 + ancillary + jumps);
    if (interweave) {
      CHECK(one.ancillary_k_acceptance > 0.0);
      CHECK(one.ancillary_kt_acceptance > 0.0);
    }
  }
}

TEST_CASE("the interwoven chain and the centred-only chain agree on a 10-truck posterior",
          "[fleet][mcmc][interweave][long]") {
  // The whole chain, quarter car included: both target the same posterior, so their means agree
  // within the Monte Carlo error of the two (se = sd / sqrt(ESS) each). 10 trucks leave sigma_kt
  // broad and heavy-tailed, so it is the slowest coordinate; ESS is required to be adequate first.
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks =
      fleet::draw_fleet(fleet::FleetDistribution{}, 10, site.lateral_min_m(), site.lateral_max_m(), 77);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 77);
  fleet::BatchMcmcOptions o;
  o.iterations = 120000;
  o.burn_in = 10000;
  o.seed = 8;
  o.interweave = false;
  const auto centred = fleet::run_batch_mcmc(site, log.records, o);
  o.interweave = true;  // every block
  o.interweave_stiffness = o.interweave_tyre_stiffness = o.interweave_lateral = true;
  o.iterations = 60000;
  o.seed = 9;
  const auto interwoven = fleet::run_batch_mcmc(site, log.records, o);
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const Eigen::VectorXd a = centred.theta_draws.col(j), b = interwoven.theta_draws.col(j);
    const double ess_a = chain_effective_sample_size(a), ess_b = chain_effective_sample_size(b);
    auto sd = [](const Eigen::VectorXd& v) {
      return std::sqrt((v.array() - v.mean()).square().sum() / static_cast<double>(v.size() - 1));
    };
    const double se = std::sqrt(sd(a) * sd(a) / ess_a + sd(b) * sd(b) / ess_b);
    INFO(fleet::kHyperNames[static_cast<std::size_t>(j)]
         << ": centred mean " << a.mean() << " sd " << sd(a) << " ESS " << ess_a << "; interwoven mean "
         << b.mean() << " sd " << sd(b) << " ESS " << ess_b << "; difference " << (b.mean() - a.mean()) / se
         << " se");
    REQUIRE(ess_a > 200.0);
    REQUIRE(ess_b > 200.0);
    CHECK(std::abs(a.mean() - b.mean()) < 4.5 * se);
  }
}
