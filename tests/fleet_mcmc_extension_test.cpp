// The batch MCMC with a model extension (batch_mcmc.hpp step 5): ψ joins the chain through the
// same densities and forward model as the latent SMC core, and the two agree on every extension of
// the catalogue.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "latent_particle.hpp"

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_residuals.hpp"
#include "fleet/fleet_smc.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_extension.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;

namespace {

const site::Site& as1() {
  static const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  return site;
}

// Each extension switched on at a realistic size (the magnitudes of diagnose_test's long cases).
const std::map<std::string, std::string>& hidden_effects() {
  static const std::map<std::string, std::string> settings = {
      {"profile_defect", "profile_defect:position=84.3,length=0.5,height=0.01"},
      {"second_class", "second_class:share=0.3,K2=1000000,sigma_k2=100000"},
      {"sensor_gain", "sensor_gain:sensor=5,gain=1.05"},
      {"speed_bias", "speed_bias:factor=1.05"},
      {"suspension_damping", "suspension_damping:c_b=35000"},
      {"tyre_damping", "tyre_damping:c_t=2000"},
      {"unsprung_mass", "unsprung_mass:m1=600"},
  };
  return settings;
}

struct HiddenEffectLog {
  std::vector<records::Truck> trucks;  // as they drove (second_class edits k)
  std::vector<records::WimRecord> records;
};

// Table 1 fleet on AS1, sigma_IF = 0.02, with the named extension's effect in the data.
HiddenEffectLog hidden_effect_log(const std::string& name, int trucks, std::uint64_t seed) {
  const auto& site = as1();
  const auto fleet = fleet::draw_fleet(fleet::FleetDistribution{}, trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  const auto effect = fleet::parse_extension_setting(hidden_effects().at(name), site);
  const auto log = fleet::simulate_log(site, fleet, 0.02, seed, *effect.extension, effect.psi);
  return {log.trucks, log.records};
}

Eigen::MatrixXd latents_of(const std::vector<records::Truck>& trucks) {
  Eigen::MatrixXd x(static_cast<Eigen::Index>(trucks.size()), 3);
  for (std::size_t i = 0; i < trucks.size(); ++i) {
    x.row(static_cast<Eigen::Index>(i)) << trucks[i].stiffness_npm, trucks[i].tyre_stiffness_npm, trucks[i].lateral_m;
  }
  return x;
}

std::vector<double> null_psi(const fleet::ModelExtension& ext) {
  std::vector<double> psi;
  for (const auto& p : ext.parameters()) psi.push_back(p.null_value);
  return psi;
}

}  // namespace

TEST_CASE("the catalogue of the extension tests is the registered catalogue", "[fleet][mcmc][extension]") {
  // The agreement test below runs every registered extension; a new one needs a hidden effect here.
  for (const auto& name : fleet::extension_names()) {
    INFO(name);
    CHECK(hidden_effects().count(name) == 1);
  }
}

TEST_CASE("an extension at its null psi reproduces the base model's log density exactly", "[fleet][mcmc][extension]") {
  const auto& site = as1();
  const auto data = hidden_effect_log("tyre_damping", 12, 3);
  const Eigen::MatrixXd x = latents_of(data.trucks);
  const fleet::detail::Observations obs = fleet::detail::gather(site, data.records);
  std::vector<int> all(x.rows());
  for (int n = 0; n < static_cast<int>(x.rows()); ++n) all[static_cast<std::size_t>(n)] = n;
  const fleet::LateralRange range{site.lateral_min_m(), site.lateral_max_m()};
  const fleet::PriorBounds prior;
  const fleet::HyperVector theta{480e3, 60e3, 1.9e6, 210e3, 1.4, 0.55, 0.021};

  Eigen::ArrayXd base_ssr;
  fleet::detail::ResidualEvaluator base(site, obs, 2);
  base.evaluate(all, x.col(0).array(), x.col(1).array(), x.col(2).array(), nullptr, base_ssr);
  const double base_density = fleet::log_posterior_unnormalised(theta, x, base_ssr.matrix(), site.sensors(), prior, range);
  REQUIRE(std::isfinite(base_density));

  for (const auto& name : fleet::extension_names()) {
    INFO(name);
    const auto ext = fleet::make_extension(name, site);
    const std::vector<double> psi = null_psi(*ext);
    fleet::detail::ResidualEvaluator extended(site, obs, 2, ext.get());
    Eigen::ArrayXd ssr;
    extended.evaluate(all, x.col(0).array(), x.col(1).array(), x.col(2).array(), psi.data(), ssr);
    // The same forward model, bit for bit, and the same density up to ψ's prior, bit for bit.
    CHECK((ssr == base_ssr).all());
    const double density =
        fleet::log_posterior_unnormalised(theta, x, ssr.matrix(), site.sensors(), prior, range, ext.get(), psi.data());
    CHECK(density == base_density + ext->log_prior(psi.data()));
    // Not vacuous: the hidden effect's own ψ gives another density.
    const auto effect = fleet::parse_extension_setting(hidden_effects().at(name), site);
    extended.evaluate(all, x.col(0).array(), x.col(1).array(), x.col(2).array(), effect.psi.data(), ssr);
    CHECK(fleet::log_posterior_unnormalised(theta, x, ssr.matrix(), site.sensors(), prior, range, ext.get(),
                                            effect.psi.data()) != density);
  }
}

TEST_CASE("bad extension options of the batch MCMC are refused naming the option", "[fleet][mcmc][extension]") {
  const auto gain = fleet::make_extension("sensor_gain", as1());
  const auto second = fleet::make_extension("second_class", as1());
  struct Case {
    std::function<void(fleet::BatchMcmcOptions&)> change;
    const char* name;
  };
  const Case cases[] = {
      {[&](auto& o) { o.psi_moves_per_sweep = 0; }, "psi_moves_per_sweep"},
      {[&](auto& o) { o.psi_jump_every = -1; }, "psi_jump_every"},
      {[&](auto& o) { o.psi_initial_step = 0.0; }, "psi_initial_step"},
      {[&](auto& o) { o.psi_initial_step = 2.0; }, "psi_initial_step"},
      {[&](auto& o) { o.stiffness_moves_per_sweep = 0; }, "stiffness_moves_per_sweep"},
      {[&](auto& o) { o.initial_psi = std::vector<double>{5.0, 1.05}; }, "initial_psi"},  // no extension
      {[&](auto& o) {
         o.extension = gain.get();
         o.initial_psi = std::vector<double>{5.0};
       },
       "initial_psi size"},
      {[&](auto& o) {
         o.extension = gain.get();
         o.initial_psi = std::vector<double>{5.0, 1.5};  // gain's box is [0.8, 1.2]
       },
       "initial_psi"},
      {[&](auto& o) {
         o.extension = second.get();
         o.interweave_stiffness = true;
       },
       "interweave_stiffness"},
  };
  for (const Case& c : cases) {
    fleet::BatchMcmcOptions o;
    c.change(o);
    std::string message;
    INFO("option " << c.name);
    CHECK_FALSE(o.IsValid(&message));
    CHECK_THAT(message, Catch::Contains(c.name));
    CHECK_THROWS_WITH(fleet::run_batch_mcmc(as1(), hidden_effect_log("sensor_gain", 2, 1).records, o),
                      Catch::Contains(c.name));
  }
  // The same options are fine where they fit.
  fleet::BatchMcmcOptions o;
  o.extension = gain.get();
  o.initial_psi = std::vector<double>{5.0, 1.05};
  std::string message;
  CHECK(o.IsValid(&message));
  o.extension = second.get();
  o.initial_psi.reset();
  o.interweave_stiffness = true;
  o.interweave = false;  // no ancillary step at all: nothing to refuse
  CHECK(o.IsValid(&message));
}

TEST_CASE("with every extension the batch MCMC moves psi and keeps it in its prior box", "[fleet][mcmc][extension]") {
  for (const auto& name : fleet::extension_names()) {
    INFO(name);
    const auto data = hidden_effect_log(name, 20, 41);
    const auto ext = fleet::make_extension(name, as1());
    fleet::BatchMcmcOptions o;
    o.iterations = 300;
    o.burn_in = 150;
    o.hold_theta_sweeps = 20;
    o.seed = 3;
    o.threads = 2;
    o.extension = ext.get();
    o.initial_latents = latents_of(data.trucks);  // skips the best-fit search: this test is about ψ
    const auto r = fleet::run_batch_mcmc(as1(), data.records, o);
    REQUIRE(r.psi_draws.rows() == r.theta_draws.rows());
    REQUIRE(r.psi_draws.cols() == ext->dim());
    for (std::size_t j = 0; j < r.initial_psi.size(); ++j) {
      CHECK(r.initial_psi[j] >= ext->parameters()[j].lo);
      CHECK(r.initial_psi[j] <= ext->parameters()[j].hi);
    }
    int moves = 0;
    for (Eigen::Index i = 0; i < r.psi_draws.rows(); ++i) {
      const Eigen::VectorXd psi = r.psi_draws.row(i).transpose();
      CHECK(ext->in_prior(psi.data()));
      if (i > 0 && r.psi_draws.row(i) != r.psi_draws.row(i - 1)) ++moves;
    }
    INFO("psi acceptance " << r.psi_acceptance << ", jump acceptance " << r.psi_jump_acceptance << ", " << moves
                           << " moves in " << r.psi_draws.rows() << " kept sweeps");
    CHECK(moves > 0);
    CHECK(r.psi_acceptance > 0.0);
    CHECK(r.log_target.allFinite());
    if (ext->edits_stiffness_distribution()) {
      // (K, σ_k) move by MH, not Gibbs: their acceptance is a rate, not 1.
      CHECK(r.stiffness_acceptance > 0.0);
      CHECK(r.stiffness_acceptance < 1.0);
      CHECK(r.sigma_k_acceptance == r.stiffness_acceptance);
    }
  }
}

TEST_CASE("the batch MCMC without an extension draws no psi", "[fleet][mcmc][extension]") {
  const auto data = hidden_effect_log("sensor_gain", 5, 7);
  fleet::BatchMcmcOptions o;
  o.iterations = 40;
  o.burn_in = 20;
  o.hold_theta_sweeps = 5;
  o.threads = 1;
  o.initial_latents = latents_of(data.trucks);
  const auto r = fleet::run_batch_mcmc(as1(), data.records, o);
  CHECK(r.psi_draws.cols() == 0);
  CHECK(r.psi_draws.rows() == r.theta_draws.rows());
  CHECK(r.initial_psi.empty());
}

TEST_CASE("with every extension the SMC target's density equals the batch MCMC's log posterior up to one constant",
          "[fleet][mcmc][smc][extension]") {
  // Both samplers target one posterior: after the last stage (φ = 1) each particle's log γ + ℓ is the
  // full log posterior of its state (θ, ψ, latents), which the batch MCMC's log posterior must
  // reproduce up to a constant (ψ's uniform prior, which the SMC leaves out) for every particle.
  const auto& site = as1();
  const fleet::LateralRange range{site.lateral_min_m(), site.lateral_max_m()};
  for (const auto& name : fleet::extension_names()) {
    INFO(name);
    const auto data = hidden_effect_log(name, 6, 11);
    const auto ext = fleet::make_extension(name, site);
    fleet::FleetSmc::Options o;
    o.sampler.particles = 64;
    o.sampler.threads = 1;
    o.sampler.seed = 3;
    o.extension = ext.get();
    fleet::FleetSmc smc(site, o);
    for (const auto& r : data.records) smc.absorb(r);
    auto& target = const_cast<fleet::FleetTarget&>(smc.target());
    const Eigen::Index P = target.particles(), n = target.kept_trucks();
    Eigen::ArrayXd log_base(P), loglik(P);
    target.log_density(log_base, loglik, smc::ParallelFor(1));
    std::vector<double> offsets;
    for (Eigen::Index i = 0; i < P; ++i) {
      const fleet::HyperVector theta = test::particle_theta(target, i);
      const Eigen::MatrixXd latents = test::particle_latents(target, n, i);
      const Eigen::VectorXd ssr = target.sums_of_squared_residuals().col(i);
      const Eigen::VectorXd psi = target.psi().col(i);
      offsets.push_back(log_base[i] + loglik[i] -
                        fleet::log_posterior_unnormalised(theta, latents, ssr, site.sensors(), fleet::PriorBounds{}, range,
                                                          ext.get(), psi.data()));
    }
    // Rounding is judged against the size of the density (the SMC sums it in another order).
    const double scale = std::abs(log_base[0] + loglik[0]);
    for (double offset : offsets) CHECK(offset == Approx(offsets.front()).margin(1e-7 * scale));
  }
}

namespace {

struct Moments {
  double mean = 0.0, sd = 0.0;
};

Moments weighted_moments(const Eigen::VectorXd& x, const Eigen::ArrayXd& w) {
  const double total = w.sum();
  const double mean = (x.array() * w).sum() / total;
  return {mean, std::sqrt(((x.array() - mean).square() * w).sum() / total)};
}

}  // namespace

// One fleet model for every algorithm. For every registered extension, on one simulated
// log with that extension's effect hidden in it, the latent SMC core and the batch MCMC, each fitting
// the extension, must give the same posterior means of the 7 hyperparameters and of every ψ
// component, within 0.25 posterior sd.
//
// Tolerance. The offset of two Monte Carlo estimates of one mean has, in posterior-sd units, the
// sd sqrt(1/ESS_mcmc + se_smc^2) when both target the same posterior:
//  - the MCMC's: 1/sqrt(ESS) from the chain's own ESS (Geyer, util/effective_sample_size.hpp);
//  - the SMC's: measured, not assumed: kSmcRuns SMC runs with different seeds; the sample variance
//    s^2 of their means (kSmcRuns - 1 degrees of freedom per parameter) estimates one run's
//    se^2, so their average has se_smc^2 = s^2 / kSmcRuns, pooled (mean square) over the
//    extension's parameters.
// The test first requires that combined Monte Carlo sd to be at most 0.25 / 3 for every parameter
// (otherwise a 0.25 sd threshold could not tell a real disagreement from noise, and the test says
// so rather than passing), then the offset to be under 0.25 sd: at least 3 Monte Carlo sd, so a
// failure flags a difference between the samplers' posteriors, not their noise.
//
// One section per extension (run one alone with -c <name>; the WARN records its numbers).
//
// Measured at commit c2230d2 (the tyre-stiffness interweave in the latent core), 2 cores shared
// with other jobs (load 4-8); 50 trucks, 1024 particles and 50 final sweeps per SMC run, 30,000
// MCMC sweeps of which 25,000 kept; largest |offset| over the 7 + d parameters; two SMC runs then:
//   sensor_gain 0.046 sd, SMC se 0.037, min MCMC ESS 1319; second_class 0.085 (share), se 0.020,
//   ESS 977; speed_bias 0.053 (K; sigma_kt -0.002, was -0.30 before the interweave, its seeds 0.42
//   sd apart), se 0.024, ESS 341 on the factor; suspension_damping 0.066, se 0.025, ESS 337;
//   tyre_damping 0.067, se 0.027, ESS 1107; unsprung_mass 0.062, se 0.022, ESS 2285: all pass.
//   SMC 144-228 s, MCMC 54-256 s each.
//   profile_defect: offsets all under 0.25 (0.224 on the length) but the Monte Carlo check failed,
//   0.084-0.091 > 0.083: SMC se 0.079, the runs 0.35 sd apart on the length. With four runs
//   (kSmcRuns): largest offset 0.086 sd (length), SMC se 0.052, run-to-run sd 0.22 on length and
//   height, MCMC ESS 521-647 on psi; pass. SMC 508 s (4 runs), MCMC 83 s.
// Before the joint jumps and the class swap, second_class had one stiff truck stuck in a softer
// (k, k_t, z) mode in the MCMC (sigma_IF 4.2 sd off) and a label-swapped mode one SMC seed gave 10 %
// of its weight; before the ridge coordinates, profile_defect's MCMC had ESS 7-10 on psi.
TEST_CASE("the latent SMC and the batch MCMC agree on every extension's posterior within a quarter sd",
          "[fleet][mcmc][smc][extension][long]") {
  constexpr int kTrucks = 50;
  constexpr Eigen::Index kParticles = 1024;
  constexpr int kMcmcIterations = 30000, kMcmcBurnIn = 5000;
  // Four runs, not two: with two, the SMC's seed scatter on profile_defect's length-height ridge
  // (one pair of runs 0.35 sd apart on the length) put the Monte Carlo sd of the comparison at
  // 0.084-0.091 sd, just over the 0.083 the test needs to resolve 0.25 sd; averaging four halves
  // the SMC's share of it and estimates it from 3 degrees of freedom per parameter.
  constexpr std::uint64_t kSmcRuns = 4;
  constexpr double kTolerance = 0.25;  // posterior sd
  const auto& site = as1();
  for (const auto& name : fleet::extension_names()) {
    // One section per extension, so one can be run alone: -c speed_bias.
    DYNAMIC_SECTION(name) {
      const auto t0 = std::chrono::steady_clock::now();
      const auto data = hidden_effect_log(name, kTrucks, 2024);
      const auto ext = fleet::make_extension(name, site);
      const Eigen::Index d = ext->dim();

      // The SMC, kSmcRuns times (seeds 1, 2, ...): θ and ψ per particle, with the cloud's weights.
      std::vector<Eigen::MatrixXd> smc_states;  // (7 + d) x P
      std::vector<Eigen::ArrayXd> smc_weights;
      for (std::uint64_t seed = 1; seed <= kSmcRuns; ++seed) {
        fleet::FleetSmc::Options o;  // the latent core's defaults (`fit --core latent`, diagnose)
        o.sampler.particles = kParticles;
        o.sampler.threads = 2;
        o.sampler.seed = seed;
        o.extension = ext.get();
        fleet::FleetSmc smc(site, o);
        for (const auto& r : data.records) smc.absorb(r);
        smc.rejuvenate(o.sampler.schedule.final_sweeps);
        const auto cloud = smc.cloud();
        Eigen::MatrixXd state(fleet::kHyperCount + d, kParticles);
        state.topRows(fleet::kHyperCount) = cloud.theta;
        state.bottomRows(d) = smc.target().psi();
        smc_states.push_back(state);
        smc_weights.push_back(cloud.weights);
      }
      const double smc_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

      fleet::BatchMcmcOptions o;
      o.iterations = kMcmcIterations;
      o.burn_in = kMcmcBurnIn;
      o.seed = 7;
      o.threads = 2;
      o.extension = ext.get();
      const auto r = fleet::run_batch_mcmc(site, data.records, o);
      Eigen::MatrixXd chain(r.theta_draws.rows(), fleet::kHyperCount + d);
      chain << r.theta_draws, r.psi_draws;

      std::vector<std::string> names(fleet::kHyperNames.begin(), fleet::kHyperNames.end());
      for (const auto& p : ext->parameters()) names.push_back(name + "." + p.name);
      const Eigen::Index J = fleet::kHyperCount + d;
      std::vector<double> offset(J), mcmc_se(J), smc_spread(J), ess(J), smc_mean(J), mcmc_mean(J), mcmc_sd(J);
      double pooled = 0.0;
      for (Eigen::Index j = 0; j < J; ++j) {
        const Eigen::VectorXd c = chain.col(j);
        const double mean = c.mean(), sd = std::sqrt((c.array() - mean).square().mean());
        std::vector<double> run_means;
        for (std::size_t k = 0; k < smc_states.size(); ++k) {
          run_means.push_back(weighted_moments(smc_states[k].row(j).transpose(), smc_weights[k]).mean);
        }
        double m = 0.0, s2 = 0.0;
        for (double v : run_means) m += v / static_cast<double>(kSmcRuns);
        for (double v : run_means) s2 += (v - m) * (v - m) / static_cast<double>(kSmcRuns - 1);
        ess[j] = chain_effective_sample_size(c);
        mcmc_se[j] = 1.0 / std::sqrt(ess[j]);
        smc_spread[j] = std::sqrt(s2) / sd;  // one run's seed-to-seed sd, in posterior sd
        pooled += smc_spread[j] * smc_spread[j];
        offset[j] = (m - mean) / sd;
        smc_mean[j] = m;
        mcmc_mean[j] = mean;
        mcmc_sd[j] = sd;
      }
      const double smc_se = std::sqrt(pooled / static_cast<double>(J) / static_cast<double>(kSmcRuns));
      const double mcmc_seconds = r.wall_seconds;
      std::ostringstream report;
      report << name << ": SMC " << smc_seconds << " s (" << kSmcRuns << " runs), MCMC " << mcmc_seconds << " s (" << kMcmcIterations
             << " sweeps), psi acceptance " << r.psi_acceptance << ", jump " << r.psi_jump_acceptance
             << ", joint latent jump " << r.joint_jump_acceptance << ", SMC se " << smc_se << " sd\n";
      for (Eigen::Index j = 0; j < J; ++j) {
        report << "  " << names[static_cast<std::size_t>(j)] << ": SMC mean " << smc_mean[j] << ", MCMC mean "
               << mcmc_mean[j] << " (sd " << mcmc_sd[j] << "), offset " << offset[j] << " sd, MCMC ESS " << ess[j]
               << ", SMC run-to-run sd " << smc_spread[j] << " sd\n";
      }
      WARN(report.str());  // the measured offsets and times, for the record
      for (Eigen::Index j = 0; j < J; ++j) {
        INFO(report.str() << names[static_cast<std::size_t>(j)]);
        const double monte_carlo_sd = std::sqrt(mcmc_se[j] * mcmc_se[j] + smc_se * smc_se);
        CHECK(monte_carlo_sd <= kTolerance / 3.0);
        CHECK(std::abs(offset[j]) < kTolerance);
      }
    }
  }
}
