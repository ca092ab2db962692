// Model extensions on the marginal core (fleet/marginal_target.hpp): an effect that changes the
// fleet's stiffness distribution alone (second_class) reweights the tables' nodes with its mixture,
// exactly, so it fits with the marginal core's flat cost per truck, its ψ in the particles.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "marginal_checkpoint_bytes.hpp"

#include "fleet/batch_mcmc.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/online_fit.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_extension.hpp"
#include "model/model_spec.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/binary_io.hpp"
#include "util/effective_sample_size.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

const site::Site& as1() {
  static const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  return site;
}

// Table 1 fleet on AS1 with a second class of stiff trucks hidden in it, sigma_IF = 0.02.
std::vector<records::WimRecord> two_class_log(int trucks, std::uint64_t seed) {
  const auto& site = as1();
  const auto fleet = fleet::draw_fleet(fleet::FleetDistribution{}, trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  const auto effect = fleet::parse_extension_setting("second_class:share=0.3,K2=1000000,sigma_k2=100000", site);
  return fleet::simulate_log(site, fleet, 0.02, seed, *effect.extension, effect.psi).records;
}

fleet::MarginalSmc::Options options(Eigen::Index particles, std::uint64_t seed, const fleet::ModelExtension* ext) {
  fleet::MarginalSmc::Options o;  // the defaults `ssrfleet fit` uses
  o.sampler.particles = particles;
  o.sampler.threads = 2;
  o.sampler.seed = seed;
  o.target.extension = ext;
  return o;
}

using test::bytes_of;
using test::restore_from;

double log_sum(double log_a, double a_weight, double log_b, double b_weight) {
  const double top = std::max(log_a, log_b);
  return top + std::log(a_weight * std::exp(log_a - top) + b_weight * std::exp(log_b - top));
}

}  // namespace

TEST_CASE("second_class's stiffness mixture is its stiffness density", "[marginal][extension]") {
  const auto ext = fleet::make_extension("second_class", as1());
  for (const double share : {0.0, 0.2, 0.5}) {
    const double psi[] = {share, 800e3, 70e3};
    const auto mixture = ext->stiffness_mixture(psi, 450e3, 50e3);
    for (double k = 200e3; k <= 1.2e6; k += 50e3) {
      double density = 0.0;
      for (const auto& c : mixture) {
        const double a = (k - c.mean_npm) / c.sd_npm;
        density += c.weight * std::exp(-0.5 * a * a) / (c.sd_npm * std::sqrt(2.0 * M_PI));
      }
      INFO("share " << share << ", k " << k);
      CHECK(std::log(density) == Approx(ext->log_stiffness_density(psi, k, 450e3, 50e3)).epsilon(1e-12));
    }
  }
}

TEST_CASE("under a stiffness mixture each truck's marginal likelihood is the mixture of the classes' likelihoods",
          "[marginal][extension]") {
  // ∫ L(k) [(1 - w) N(k | K, σ_k²) + w N(k | K2, σ_k2²)] dk = (1 - w) ℓ(K, σ_k) + w ℓ(K2, σ_k2): the
  // node sum is linear in the node weights, so the mixture's ℓ_i must be the classes' ℓ_i mixed,
  // to the single precision of the sum (a missing normalising term would be off by nats).
  const auto records = two_class_log(12, 31);
  const auto ext = fleet::make_extension("second_class", as1());
  fleet::MarginalSmc smc(as1(), options(64, 1, ext.get()));
  for (const auto& r : records) smc.absorb(r);
  const fleet::MarginalTarget& target = smc.target();
  const model::FleetMarginal& marginal = target.marginal();
  fleet::HyperVector theta{450e3, 50e3, 1.6e6, 200e3, 1.5, 0.5, 0.02};
  for (const double share : {0.1, 0.3, 0.5}) {
    for (const double k2 : {700e3, 1000e3}) {
      const double psi[] = {share, k2, 90e3};
      fleet::HyperVector second = theta;
      second[fleet::kK] = k2;
      second[fleet::kSigmaK] = 90e3;
      const model::ThetaTerms first_terms = marginal.prepare(theta), second_terms = marginal.prepare(second);
      const model::ThetaTerms mixed = target.terms_for(marginal, theta, psi);
      // Tabulated over no k index at all: every node's weight computed on the spot, the same bits.
      const model::ThetaTerms untabulated =
          marginal.prepare(theta, ext->stiffness_mixture(psi, theta[fleet::kK], theta[fleet::kSigmaK]), 0, -1);
      REQUIRE(mixed.has_k_mixture());
      REQUIRE_FALSE(mixed.k_log_density.empty());
      for (std::size_t i = 0; i < target.tables().trucks(); ++i) {
        const auto view = target.tables().view(i);
        const double expected = log_sum(marginal.log_likelihood(view, first_terms), 1.0 - share,
                                        marginal.log_likelihood(view, second_terms), share);
        const double got = marginal.log_likelihood(view, mixed);
        INFO("truck " << i << ", share " << share << ", K2 " << k2);
        CHECK(got == Approx(expected).margin(2e-4));
        CHECK(marginal.log_likelihood(view, untabulated) == got);
      }
    }
  }
  // At share 0 the extension is the base model, bit for bit.
  const double null_psi[] = {0.0, 1e6, 90e3};
  const model::ThetaTerms base = marginal.prepare(theta), at_null = target.terms_for(marginal, theta, null_psi);
  CHECK_FALSE(at_null.has_k_mixture());
  for (std::size_t i = 0; i < target.tables().trucks(); ++i)
    CHECK(marginal.log_likelihood(target.tables().view(i), at_null) == marginal.log_likelihood(target.tables().view(i), base));
}

TEST_CASE("second_class fits on the marginal core: psi in the cloud, a bit-identical resume, another model refused",
          "[marginal][extension]") {
  const auto records = two_class_log(30, 32);
  const auto ext = fleet::make_extension("second_class", as1());
  fleet::MarginalSmc first(as1(), options(128, 5, ext.get()));
  for (std::size_t i = 0; i < 15; ++i) first.absorb(records[i]);
  const std::string saved = bytes_of(first);
  fleet::MarginalSmc resumed(as1(), options(128, 5, ext.get()));
  restore_from(resumed, saved);
  for (std::size_t i = 15; i < records.size(); ++i) {
    first.absorb(records[i]);
    resumed.absorb(records[i]);
  }
  CHECK(bytes_of(first) == bytes_of(resumed));
  // The stiffness jump ran in the schedule (two classes trading places).
  const auto moves = first.target().model_moves();
  REQUIRE(moves == std::vector<std::string>{"stiffness jump"});
  const auto cloud = first.cloud();
  CHECK(cloud.model == "second_class");
  CHECK(cloud.psi_names == std::vector<std::string>{"share", "K2", "sigma_k2"});
  REQUIRE(cloud.psi.rows() == 3);
  REQUIRE(cloud.psi.cols() == cloud.theta.cols());
  for (Eigen::Index p = 0; p < cloud.psi.cols(); ++p) CHECK(ext->in_prior(cloud.psi.col(p).data()));
  // A base-model run refuses the state, naming both models.
  fleet::MarginalSmc base(as1(), options(128, 5, nullptr));
  CHECK_THROWS_WITH(restore_from(base, saved), Catch::Contains("second_class") && Catch::Contains("base"));
}

TEST_CASE("the marginal core refuses an effect it does not carry, naming it and the latent core",
          "[marginal][extension]") {
  for (const std::string name : {"sensor_gain", "profile_defect"}) {
    const auto ext = fleet::make_extension(name, as1());
    CHECK_THROWS_AS(fleet::MarginalSmc(as1(), options(64, 1, ext.get())), UsageError);
    fleet::OnlineFitOptions o;
    o.extension = ext.get();
    CHECK_THROWS_WITH(fleet::make_online_fit(as1(), o), Catch::Contains("latent") && Catch::Contains("'" + name + "'"));
    CHECK(fleet::choose_core(ext.get()) == fleet::Core::kLatent);
    CHECK_THROWS_WITH(fleet::choose_core(ext.get(), fleet::Core::kMarginal),
                      fleet::OnlineFitOptions::marginal_refusal(*ext));
    CHECK(fleet::choose_core(ext.get(), fleet::Core::kLatent) == fleet::Core::kLatent);
  }
  for (const std::string name : {"second_class", "tyre_damping", "unsprung_mass", "suspension_damping"}) {
    const auto ext = fleet::make_extension(name, as1());
    CHECK(fleet::choose_core(ext.get()) == fleet::Core::kMarginal);
    CHECK(fleet::choose_core(ext.get(), fleet::Core::kLatent) == fleet::Core::kLatent);
  }
  // A gain on a given sensor is carried too (a gain with its sensor free is not), on the marginal
  // core by default.
  const auto gain = fleet::parse_model_spec("sensor_gain:sensor=5", as1()).extension;
  CHECK(fleet::OnlineFitOptions::marginal_carries(gain.get()));
  CHECK(fleet::choose_core(gain.get()) == fleet::Core::kMarginal);
  CHECK(fleet::choose_core(gain.get(), fleet::Core::kLatent) == fleet::Core::kLatent);
  // speed_bias is carried, but its tables are dear: the latent core by default, the marginal one
  // when asked.
  const auto speed = fleet::make_extension("speed_bias", as1());
  CHECK(fleet::choose_core(speed.get()) == fleet::Core::kLatent);
  CHECK(fleet::OnlineFitOptions::marginal_carries(speed.get()));
  CHECK(fleet::choose_core(speed.get(), fleet::Core::kMarginal) == fleet::Core::kMarginal);
  CHECK(fleet::choose_core(nullptr) == fleet::Core::kMarginal);
  CHECK(fleet::choose_core(nullptr, fleet::Core::kLatent) == fleet::Core::kLatent);
}

// The marginal core and the exact batch MCMC (no tables), each fitting second_class, on one 50-truck
// log with a second class hidden in it: every posterior mean of θ and ψ within 0.25 posterior sd.
// The tolerance is argued as in the latent core's cross-sampler test (fleet_mcmc_extension_test.cpp):
// the Monte Carlo sd of the offset, sqrt(1/ESS_mcmc + se_smc²) with se_smc from the spread of four
// SMC runs, must be at most 0.25 / 3 for the comparison to mean anything, and then the offset must be
// under 0.25 sd.
TEST_CASE("the marginal core and the batch MCMC agree on second_class's posterior within a quarter sd",
          "[marginal][mcmc][extension][long]") {
  constexpr int kTrucks = 50;
  constexpr Eigen::Index kParticles = 1024;
  constexpr std::uint64_t kSmcRuns = 4;
  constexpr double kTolerance = 0.25;
  const auto records = two_class_log(kTrucks, 2024);
  const auto ext = fleet::make_extension("second_class", as1());
  const Eigen::Index d = ext->dim(), J = fleet::kHyperCount + d;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Eigen::MatrixXd> states;
  std::vector<Eigen::ArrayXd> weights;
  for (std::uint64_t seed = 1; seed <= kSmcRuns; ++seed) {
    fleet::MarginalSmc smc(as1(), options(kParticles, seed, ext.get()));
    for (const auto& r : records) smc.absorb(r);
    smc.rejuvenate(15);
    const auto cloud = smc.cloud();
    Eigen::MatrixXd state(J, cloud.theta.cols());
    state.topRows(fleet::kHyperCount) = cloud.theta;
    state.bottomRows(d) = cloud.psi;
    states.push_back(state);
    weights.push_back(cloud.weights);
  }
  const double smc_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fleet::BatchMcmcOptions o;
  o.iterations = 30000;
  o.burn_in = 5000;
  o.seed = 7;
  o.threads = 2;
  o.extension = ext.get();
  const auto r = fleet::run_batch_mcmc(as1(), records, o);
  Eigen::MatrixXd chain(r.theta_draws.rows(), J);
  chain << r.theta_draws, r.psi_draws;
  std::vector<std::string> names(fleet::kHyperNames.begin(), fleet::kHyperNames.end());
  for (const auto& p : ext->parameters()) names.push_back("second_class." + p.name);
  std::vector<double> offset(J), mcmc_se(J), spread(J);
  double pooled = 0.0;
  std::ostringstream report;
  report << "second_class on the marginal core: SMC " << smc_seconds << " s (" << kSmcRuns << " runs), MCMC "
         << r.wall_seconds << " s\n";
  for (Eigen::Index j = 0; j < J; ++j) {
    const Eigen::VectorXd c = chain.col(j);
    const double mean = c.mean(), sd = std::sqrt((c.array() - mean).square().mean());
    double m = 0.0, s2 = 0.0;
    std::vector<double> run_means;
    for (std::size_t k = 0; k < states.size(); ++k)
      run_means.push_back((states[k].row(j).transpose().array() * weights[k]).sum());
    for (double v : run_means) m += v / static_cast<double>(kSmcRuns);
    for (double v : run_means) s2 += (v - m) * (v - m) / static_cast<double>(kSmcRuns - 1);
    const double ess = chain_effective_sample_size(c);
    mcmc_se[j] = 1.0 / std::sqrt(ess);
    spread[j] = std::sqrt(s2) / sd;
    pooled += spread[j] * spread[j];
    offset[j] = (m - mean) / sd;
    report << "  " << names[static_cast<std::size_t>(j)] << ": SMC " << m << ", MCMC " << mean << " (sd " << sd
           << "), offset " << offset[j] << " sd, MCMC ESS " << ess << ", SMC run-to-run sd " << spread[j] << " sd\n";
  }
  const double smc_se = std::sqrt(pooled / static_cast<double>(J) / static_cast<double>(kSmcRuns));
  report << "  SMC se " << smc_se << " sd\n";
  WARN(report.str());
  for (Eigen::Index j = 0; j < J; ++j) {
    INFO(report.str() << names[static_cast<std::size_t>(j)]);
    CHECK(std::sqrt(mcmc_se[j] * mcmc_se[j] + smc_se * smc_se) <= kTolerance / 3.0);
    CHECK(std::abs(offset[j]) < kTolerance);
  }
}
