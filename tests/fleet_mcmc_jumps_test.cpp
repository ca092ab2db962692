// The batch MCMC's moves that jump between modes (batch_mcmc_jumps.hpp, the extensions' stiffness
// jump, ψ's move coordinates) leave the target invariant.
//
// The latent jumps are checked on one truck at a fixed θ (and ψ), where the target is the truck's
// conditional posterior p(k, k_t, z | y, θ, ψ) ∝ exp(log_posterior_unnormalised): a chain of joint
// and lateral jumps alone must reproduce its moments, which self-normalised importance sampling
// from a broad proposal of the test's own (not the fleet distribution the jumps draw from) gives
// through the shared density. σ_IF is raised to 0.1 so that the truck's posterior is broad enough
// for both to be cheap, yet still far from the fleet distribution (z's posterior sd ≈ 0.1 m against
// σ_z = 0.5 m). An acceptance that forgot the proposal, or a stiffness draw that is not the
// extension's stiffness density, moves the chain's means by many Monte Carlo errors.
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/LU>
#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <catch2/catch.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_jumps.hpp"
#include "fleet/batch_mcmc_residuals.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_extension.hpp"
#include "model/truncated_samplers.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;

namespace {

const site::Site& as1() {
  static const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  return site;
}

struct Estimate {
  double mean = 0.0, sd = 0.0, se = 0.0;  // se: Monte Carlo standard error of the mean
};

// One truck's posterior moments of (k, k_t, z) at θ, ψ by self-normalised importance sampling:
// k ~ N(k_centre, k_sd) (k > 0), k_t ~ N(K_t, 1.5 σ_kt) (k_t > 0), z uniform on the road.
std::array<Estimate, 3> importance_moments(fleet::detail::ResidualEvaluator& evaluator,
                                           const fleet::HyperVector& theta, const fleet::ModelExtension* ext,
                                           const double* psi, double k_centre, double k_sd, int draws,
                                           int sensors, const fleet::LateralRange& range) {
  boost::random::mt19937_64 engine(99);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const double kt_sd = 1.5 * theta[fleet::kSigmaKt];
  Eigen::MatrixXd x(draws, 3);
  Eigen::VectorXd log_w(draws);
  for (int i = 0; i < draws; ++i) {
    double k = -1.0, kt = -1.0;
    while (k <= 0.0) k = k_centre + k_sd * normal(engine);
    while (kt <= 0.0) kt = theta[fleet::kKt] + kt_sd * normal(engine);
    x.row(i) << k, kt, range.lo_m + (range.hi_m - range.lo_m) * fleet::uniform_open01(engine);
  }
  constexpr int kChunk = 1000;
  const fleet::PriorBounds prior;
  for (int begin = 0; begin < draws; begin += kChunk) {
    const int m = std::min(kChunk, draws - begin);
    const std::vector<int> which(static_cast<std::size_t>(m), 0);
    Eigen::ArrayXd ssr;
    evaluator.evaluate(which, x.col(0).segment(begin, m).array(), x.col(1).segment(begin, m).array(),
                       x.col(2).segment(begin, m).array(), psi, ssr);
    for (int i = 0; i < m; ++i) {
      const int r = begin + i;
      const Eigen::VectorXd s = Eigen::VectorXd::Constant(1, ssr[i]);
      // Target over proposal (the proposal's normalisers, equal for every draw, cancel).
      const double log_q = -0.5 * std::pow((x(r, 0) - k_centre) / k_sd, 2) -
                           0.5 * std::pow((x(r, 1) - theta[fleet::kKt]) / kt_sd, 2);
      log_w[r] =
          fleet::log_posterior_unnormalised(theta, x.row(r), s, sensors, prior, range, ext, psi) - log_q;
    }
  }
  const Eigen::ArrayXd w = (log_w.array() - log_w.maxCoeff()).exp();
  const double ess = w.sum() * w.sum() / w.square().sum();
  std::array<Estimate, 3> out;
  for (int j = 0; j < 3; ++j) {
    const double mean = (w * x.col(j).array()).sum() / w.sum();
    const double var = (w * (x.col(j).array() - mean).square()).sum() / w.sum();
    out[static_cast<std::size_t>(j)] = {mean, std::sqrt(var), std::sqrt(var / ess)};
  }
  return out;
}

// A chain of `sweeps` (joint jump, lateral jump) pairs on one truck from `start`.
std::array<Estimate, 3> jump_chain_moments(fleet::detail::ResidualEvaluator& evaluator,
                                           const fleet::HyperVector& theta, const fleet::ModelExtension* ext,
                                           const double* psi, const Eigen::RowVector3d& start, int sweeps,
                                           const fleet::LateralRange& range, double* joint_acceptance) {
  boost::random::mt19937_64 engine(2024);
  fleet::detail::LatentJumps jumps(ext, range);
  fleet::detail::JumpCounts joint, lateral;
  const std::vector<int> all{0};
  Eigen::MatrixXd latents = start;
  Eigen::ArrayXd ssr;
  evaluator.evaluate(all, latents.col(0).array(), latents.col(1).array(), latents.col(2).array(), psi, ssr);
  Eigen::MatrixXd draws(sweeps, 3);
  for (int s = 0; s < sweeps; ++s) {
    jumps.joint(engine, theta, psi, latents, ssr, evaluator, true, joint);
    jumps.lateral(engine, theta, psi, latents, ssr, evaluator, all, true, lateral);
    draws.row(s) = latents.row(0);
  }
  *joint_acceptance = joint.rate();
  std::array<Estimate, 3> out;
  for (int j = 0; j < 3; ++j) {
    const Eigen::VectorXd c = draws.col(j);
    const double mean = c.mean(), sd = std::sqrt((c.array() - mean).square().mean());
    out[static_cast<std::size_t>(j)] = {mean, sd, sd / std::sqrt(chain_effective_sample_size(c))};
  }
  return out;
}

}  // namespace

TEST_CASE("the latent jumps leave one truck's conditional posterior invariant", "[fleet][mcmc][jumps]") {
  const auto& site = as1();
  const fleet::LateralRange range{site.lateral_min_m(), site.lateral_max_m()};
  const fleet::HyperVector theta{500e3, 50e3, 1.95e6, 195e3, 1.5, 0.5, 0.04};
  // The stiffness distribution of second_class (a stiff class of 30 %) checks the extension's draw
  // against its density; the base model, the fleet's normal.
  for (const std::string name : {"", "second_class"}) {
    DYNAMIC_SECTION((name.empty() ? "base model" : name)) {
      auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 1, range.lo_m, range.hi_m, 17);
      std::unique_ptr<fleet::ModelExtension> ext;
      std::vector<double> psi;
      double k_centre = theta[fleet::kK], k_sd = 1.5 * theta[fleet::kSigmaK];
      if (!name.empty()) {
        auto setting =
            fleet::parse_extension_setting("second_class:share=0.3,K2=1000000,sigma_k2=100000", site);
        ext = std::move(setting.extension);
        psi = setting.psi;
        trucks[0].stiffness_npm = 1.0e6;  // one of the stiff class, so both classes carry mass
        k_centre = 750e3;
        k_sd = 300e3;
      }
      const auto log = fleet::simulate_log(site, trucks, 0.04, 5);
      const auto obs = fleet::detail::gather(site, log.records);
      fleet::detail::ResidualEvaluator evaluator(site, obs, 2, ext.get());
      const double* psi_ptr = psi.empty() ? nullptr : psi.data();

      const auto reference = importance_moments(evaluator, theta, ext.get(), psi_ptr, k_centre, k_sd, 100000,
                                                site.sensors(), range);
      // Started away from the truck (the fleet's mean), so a chain that never moved fails too.
      double acceptance = 0.0;
      const auto chain = jump_chain_moments(evaluator, theta, ext.get(), psi_ptr,
                                            Eigen::RowVector3d(theta[fleet::kK], theta[fleet::kKt], 3.0),
                                            20000, range, &acceptance);
      const char* names[] = {"k", "k_t", "z"};
      for (int j = 0; j < 3; ++j) {
        const auto& r = reference[static_cast<std::size_t>(j)];
        const auto& c = chain[static_cast<std::size_t>(j)];
        INFO(names[j] << ": importance " << r.mean << " +- " << r.se << " (sd " << r.sd << "), chain "
                      << c.mean << " +- " << c.se << " (sd " << c.sd << "), joint acceptance " << acceptance);
        const double se = std::hypot(r.se, c.se);
        // Not vacuous: both estimates are precise to a small part of the posterior's spread.
        CHECK(se < 0.1 * r.sd);
        CHECK(std::abs(c.mean - r.mean) < 4.0 * se);
        // The sd by its relative Monte Carlo error, about 1/sqrt(2 ESS) of each (ESS = (sd / se)^2).
        const double sd_se = std::sqrt(0.5 * (std::pow(r.se / r.sd, 2) + std::pow(c.se / c.sd, 2)));
        CHECK(std::abs(c.sd / r.sd - 1.0) < 4.0 * sd_se);
      }
      // z's posterior is far narrower than the fleet's spread: the data, not the proposal, decide.
      CHECK(reference[2].sd < 0.5 * theta[fleet::kSigmaZ]);
    }
  }
}

TEST_CASE("every extension's move coordinates invert and their log Jacobian is log |det dpsi/du|",
          "[fleet][mcmc][extension][jumps]") {
  const auto& site = as1();
  for (const auto& name : fleet::extension_names()) {
    INFO(name);
    const auto ext = fleet::make_extension(name, site);
    const auto& params = ext->parameters();
    const auto d = static_cast<std::size_t>(ext->dim());
    // Interior points of the box: 1/4, 1/2 and 3/4 of each width (a different mix per coordinate).
    for (int point = 0; point < 3; ++point) {
      std::vector<double> psi(d), u(d), back(d);
      for (std::size_t j = 0; j < d; ++j) {
        const double f = 0.25 * static_cast<double>(1 + (point + static_cast<int>(j)) % 3);
        psi[j] = params[j].lo + f * (params[j].hi - params[j].lo);
      }
      ext->to_move_coordinates(psi.data(), u.data());
      ext->from_move_coordinates(u.data(), back.data());
      for (std::size_t j = 0; j < d; ++j) CHECK(back[j] == Approx(psi[j]).epsilon(1e-12).margin(1e-15));
      // ∂ψ/∂u by central differences, its log |det| against the extension's.
      Eigen::MatrixXd jac(static_cast<Eigen::Index>(d), static_cast<Eigen::Index>(d));
      for (std::size_t j = 0; j < d; ++j) {
        const double h = 1e-6 * std::max(1.0, std::abs(u[j]));
        std::vector<double> up = u, down = u, psi_up(d), psi_down(d);
        up[j] += h;
        down[j] -= h;
        ext->from_move_coordinates(up.data(), psi_up.data());
        ext->from_move_coordinates(down.data(), psi_down.data());
        for (std::size_t i = 0; i < d; ++i) {
          jac(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
              (psi_up[i] - psi_down[i]) / (2.0 * h);
        }
      }
      CHECK(ext->log_move_jacobian(psi.data()) == Approx(std::log(std::abs(jac.determinant()))).margin(1e-5));
    }
  }
}

TEST_CASE("an extension's stiffness jump is a symmetric proposal", "[fleet][mcmc][extension][jumps]") {
  // Symmetric: jumping back from the proposal with the draws that give the old ψ returns exactly
  // the old (K, σ_k, ψ), and every draw has the same density (uniforms), so q(x -> y) = q(y -> x)
  // and the MH ratio is the target's alone (as both samplers use it).
  const auto& site = as1();
  for (const auto& name : fleet::extension_names()) {
    const auto ext = fleet::make_extension(name, site);
    if (ext->stiffness_jump_draws() == 0) continue;
    INFO(name);
    const auto& params = ext->parameters();
    const auto d = static_cast<std::size_t>(ext->dim());
    std::vector<double> psi(d), there(d), back(d);
    for (std::size_t j = 0; j < d; ++j) psi[j] = params[j].lo + 0.3 * (params[j].hi - params[j].lo);
    const double mean = 480e3, sd = 55e3;
    std::vector<double> u(static_cast<std::size_t>(ext->stiffness_jump_draws()), 0.7);
    double mean_there = 0.0, sd_there = 0.0, mean_back = 0.0, sd_back = 0.0;
    ext->stiffness_jump(psi.data(), mean, sd, u.data(), there.data(), &mean_there, &sd_there);
    CHECK((mean_there != mean || sd_there != sd || there != psi));  // it moves
    // The draws that give the old ψ back: for second_class the share is its uniform's image.
    std::vector<double> u_back(u.size());
    for (std::size_t i = 0; i < u.size(); ++i)
      u_back[i] = (psi[0] - params[0].lo) / (params[0].hi - params[0].lo);
    ext->stiffness_jump(there.data(), mean_there, sd_there, u_back.data(), back.data(), &mean_back, &sd_back);
    CHECK(mean_back == mean);
    CHECK(sd_back == sd);
    for (std::size_t j = 0; j < d; ++j) CHECK(back[j] == Approx(psi[j]).epsilon(1e-12));
  }
}
