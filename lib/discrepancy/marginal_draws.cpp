#include "discrepancy/marginal_draws.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/extended_forward.hpp"
#include "model/extension_conditionals.hpp"
#include "model/fleet_model.hpp"
#include "model/table_proposal.hpp"
#include "smc/parallel.hpp"
#include "smc/resampling.hpp"
#include "util/errors.hpp"

namespace ssrfleet::discrepancy {

namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// log p(y | x, σ) + log p(x | θ), the fleet model's densities: the exact target of the MH
// correction, from the IFs of one integrator pass at x.
double log_target(const Eigen::Ref<const Eigen::VectorXd>& observed, const Eigen::Ref<const Eigen::ArrayXd>& model_if,
                  const model::TruckLatent& x, const fleet::HyperVector& theta, const fleet::ModelExtension* extension,
                  const double* psi, const fleet::LateralRange& range) {
  const double ssr = (observed.array() - model_if).square().sum();
  return fleet::log_likelihood_from_ssr(ssr, static_cast<int>(observed.size()), theta[fleet::kSigmaIf]) +
         fleet::log_latent_density(extension, psi, x.stiffness_npm, x.tyre_stiffness_npm, x.lateral_m, theta, range);
}

}  // namespace

TruckLatentDraws draw_truck_latents(const site::Site& site, const fleet::MarginalTarget& target,
                                    const fleet::HyperVector& theta, const smc::RngFactory& streams, int mh_steps,
                                    MarginalDrawStats* stats) {
  std::vector<std::size_t> all(static_cast<std::size_t>(target.trucks()));
  for (std::size_t t = 0; t < all.size(); ++t) all[t] = t;
  return draw_truck_latents(site, target, theta, streams, mh_steps, all, stats);
}

TruckLatentDraws draw_truck_latents(const site::Site& site, const fleet::MarginalTarget& target,
                                    const fleet::HyperVector& theta, const smc::RngFactory& streams, int mh_steps,
                                    const std::vector<std::size_t>& trucks, MarginalDrawStats* stats) {
  return draw_truck_latents(site, target, theta, nullptr, streams, mh_steps, trucks, stats);
}

TruckLatentDraws draw_truck_latents(const site::Site& site, const fleet::MarginalTarget& target,
                                    const fleet::HyperVector& theta, const double* psi, const smc::RngFactory& streams,
                                    int mh_steps, const std::vector<std::size_t>& trucks, MarginalDrawStats* stats) {
  const fleet::ModelExtension* extension = psi != nullptr ? target.extension() : nullptr;
  const model::ThetaTerms terms = target.terms_for(target.marginal(), theta, psi);
  // Every truck's table, in truck order: a target on one rank (diagnose runs on one process).
  if (target.ranks().size() != 1) throw std::logic_error("draw_truck_latents: needs every truck's table (one rank)");
  const auto n = static_cast<Eigen::Index>(trucks.size());
  const int M = site.sensors();
  for (const std::size_t t : trucks) {
    if (t >= static_cast<std::size_t>(target.trucks()) || target.absorbed().impact_factors(t).size() != M) {
      throw std::logic_error("draw_truck_latents: truck " + std::to_string(t) + " is not one of this site's");
    }
  }
  const double lo = site.lateral_min_m(), hi = site.lateral_max_m();
  const fleet::LateralRange range{lo, hi};
  std::vector<smc::Rng> rng;
  std::vector<model::TableProposal> proposal;
  rng.reserve(static_cast<std::size_t>(n));
  proposal.reserve(static_cast<std::size_t>(n));
  site::TruckBatch batch;
  batch.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::size_t t = trucks[static_cast<std::size_t>(i)];
    rng.push_back(streams.stream(static_cast<std::uint64_t>(t)));
    proposal.emplace_back(target.tables().view(t), target.marginal(), terms);
    batch.speed_mps[i] = target.absorbed().speed_mps(t);
    batch.sprung_mass_kg[i] = target.absorbed().sprung_mass_kg(t);
  }
  std::vector<model::TruckLatent> x(static_cast<std::size_t>(n)), y(static_cast<std::size_t>(n));
  std::vector<double> log_p(static_cast<std::size_t>(n), kNegInf), log_q(static_cast<std::size_t>(n));
  Eigen::ArrayXXd f(M, n), g(M, n);
  long proposals = 0, accepted = 0;
  auto in_support = [&](const model::TruckLatent& c) {
    return c.stiffness_npm > 0.0 && c.tyre_stiffness_npm > 0.0 && c.lateral_m >= lo && c.lateral_m <= hi;
  };
  // Step 0 draws every truck's first state from its proposal (truncated to the support by
  // redrawing); steps 1.. propose and accept. A proposal outside the support has target density 0:
  // it is simulated at the current state (any admissible car will do) and rejected.
  for (int step = 0; step <= mh_steps; ++step) {
    std::vector<char> admissible(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto t = static_cast<std::size_t>(i);
      model::TruckLatent cand = proposal[t].draw(rng[t]);
      for (int tries = 0; step == 0 && tries < 1000 && !in_support(cand); ++tries) cand = proposal[t].draw(rng[t]);
      admissible[t] = in_support(cand);
      if (step == 0 && !admissible[t]) {
        throw NumericalError("latent draws: truck " + std::to_string(trucks[t] + 1) +
                             "'s table proposes no admissible latents");
      }
      y[t] = cand;
      const model::TruckLatent& run = admissible[t] ? cand : x[t];
      batch.stiffness_npm[i] = run.stiffness_npm;
      batch.tyre_stiffness_npm[i] = run.tyre_stiffness_npm;
      batch.lateral_m[i] = run.lateral_m;
    }
    if (extension != nullptr && extension->edits_forward()) {
      // An effect inside the dynamics (the marginal core's ψ window): the extended forward model at ψ.
      std::vector<fleet::ExtendedPass> passes(static_cast<std::size_t>(n));
      for (Eigen::Index i = 0; i < n; ++i)
        passes[static_cast<std::size_t>(i)] = {fleet::base_pass(site, batch.speed_mps[i], batch.sprung_mass_kg[i], batch.stiffness_npm[i],
                                                                batch.tyre_stiffness_npm[i], batch.lateral_m[i]),
                                               psi};
      fleet::simulate_passes(site, extension, passes, g);
    } else {
      site.impact_factors(batch, g);
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto t = static_cast<std::size_t>(i);
      if (step > 0) ++proposals;
      if (!admissible[t]) continue;
      const double lp =
          log_target(target.absorbed().impact_factors(trucks[t]), g.col(i), y[t], theta, extension, psi, range);
      const double lq = proposal[t].log_density(y[t]);
      bool take = step == 0;
      if (!take) {
        const double log_ratio = (lp - log_p[t]) + (log_q[t] - lq);
        take = log_ratio >= 0.0 || fleet::uniform_open01(rng[t]) < std::exp(log_ratio);
        if (take) ++accepted;
      }
      if (take) {
        x[t] = y[t];
        log_p[t] = lp;
        log_q[t] = lq;
        f.col(i) = g.col(i);
      }
    }
  }
  if (stats != nullptr) {
    stats->proposals += proposals;
    stats->accepted += accepted;
  }
  return {std::move(x), f.matrix()};
}

PosteriorDraws posterior_draws(const site::Site& site, const fleet::MarginalSmc& fit, const MarginalDrawOptions& o,
                               MarginalDrawStats* stats) {
  if (o.draws < 1) throw UsageError("posterior checks: draws must be at least 1");
  if (o.mh_steps < 0) throw UsageError("posterior checks: mh_steps must be >= 0");
  if (o.threads < 1) throw UsageError("posterior checks: threads must be at least 1");
  const fleet::MarginalTarget& target = fit.target();
  const auto n = static_cast<Eigen::Index>(target.trucks());
  PosteriorDraws out;
  out.observed.resize(site.sensors(), n);
  out.speed_mps.resize(n);
  out.sprung_mass_kg.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto t = static_cast<std::size_t>(i);
    out.observed.col(i) = target.absorbed().impact_factors(t);
    out.speed_mps[i] = target.absorbed().speed_mps(t);
    out.sprung_mass_kg[i] = target.absorbed().sprung_mass_kg(t);
  }
  const smc::RngFactory root = smc::RngFactory(o.seed).child(0x636865636bULL /* "check" */);
  smc::Rng pick = root.child(0).stream(0);
  const auto chosen = smc::systematic_resampling(fit.sampler().weights(), o.draws, pick);
  out.model_if.assign(chosen.size(), Eigen::MatrixXd());
  out.lateral_m.assign(chosen.size(), Eigen::VectorXd());
  out.sigma_if.assign(chosen.size(), 0.0);
  out.stiffness_pit.assign(chosen.size(), Eigen::VectorXd());
  out.tyre_stiffness_pit.assign(chosen.size(), Eigen::VectorXd());
  std::vector<MarginalDrawStats> per_draw(chosen.size());
  std::vector<std::size_t> all_trucks(static_cast<std::size_t>(n));
  for (std::size_t t = 0; t < all_trucks.size(); ++t) all_trucks[t] = t;
  const smc::ParallelFor parallel(o.threads);
  parallel(static_cast<Eigen::Index>(chosen.size()), [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index d = begin; d < end; ++d) {
      const auto slot = static_cast<std::size_t>(d);
      const Eigen::Index p = chosen[slot];
      fleet::HyperVector theta;
      for (int j = 0; j < fleet::kHyperCount; ++j) theta[static_cast<std::size_t>(j)] = target.theta()(j, p);
      const fleet::ModelExtension* extension = target.extension();
      const Eigen::VectorXd psi = target.psi().rows() > 0 ? Eigen::VectorXd(target.psi().col(p)) : Eigen::VectorXd();
      const double* psi_data = extension != nullptr ? psi.data() : nullptr;
      // Each (draw, truck) has its own stream: the draws do not depend on the thread count.
      TruckLatentDraws drawn = draw_truck_latents(site, target, theta, psi_data, root.child(1, static_cast<std::uint64_t>(d)),
                                                  o.mh_steps, all_trucks, &per_draw[slot]);
      Eigen::VectorXd lateral(n), pit(n), tyre_pit(n);
      for (Eigen::Index i = 0; i < n; ++i) {
        const auto& x = drawn.latents[static_cast<std::size_t>(i)];
        lateral[i] = x.lateral_m;
        pit[i] = extension != nullptr && extension->edits_stiffness_distribution()
                     ? extension->stiffness_cdf(psi_data, x.stiffness_npm, theta[fleet::kK], theta[fleet::kSigmaK])
                     : fleet::normal_cdf((x.stiffness_npm - theta[fleet::kK]) / theta[fleet::kSigmaK]);
        tyre_pit[i] = fleet::normal_cdf((x.tyre_stiffness_npm - theta[fleet::kKt]) / theta[fleet::kSigmaKt]);
      }
      out.model_if[slot] = std::move(drawn.model_if);
      out.lateral_m[slot] = lateral;
      out.sigma_if[slot] = theta[fleet::kSigmaIf];
      out.stiffness_pit[slot] = pit;
      out.tyre_stiffness_pit[slot] = tyre_pit;
    }
  });
  if (stats != nullptr) {
    for (const auto& s : per_draw) {
      stats->proposals += s.proposals;
      stats->accepted += s.accepted;
    }
  }
  return out;
}

}  // namespace ssrfleet::discrepancy
