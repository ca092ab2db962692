// What the posterior predictive checks need (posterior_checks.hpp), from a fit on the marginal
// core, whose particles carry θ alone: every truck's latents are drawn afresh from their exact
// conditional p(x_i | y_i, θ) for each posterior draw of θ (docs/inference.md). The draw starts from
// the truck's table (model/table_proposal.hpp) and is made exact by independence
// Metropolis–Hastings with the quarter-car integrator: the table's mixture proposes, the exact
// likelihood and fleet density accept. One integrator pass per truck per step.
#pragma once

#include <cstdint>

#include "discrepancy/posterior_checks.hpp"
#include "fleet/marginal_smc.hpp"
#include "model/table_proposal.hpp"
#include "smc/rng.hpp"
#include "site/site.hpp"

namespace ssrfleet::discrepancy {

struct MarginalDrawOptions {
  int draws = 200;        // θ draws, by systematic resampling of the weights
  // Independence MH steps per truck after the first proposal: on the Table 1 trucks of
  // tests/marginal_draws_test.cpp (AS1) the steps accept 85 %, so after 8 the chance that a truck
  // still sits at its first, approximate draw is about 0.15^8 < 1e-6.
  int mh_steps = 8;
  std::uint64_t seed = 1;
  int threads = 1;
};

struct MarginalDrawStats {
  long proposals = 0;  // MH proposals after the first draw, over every truck and θ draw
  long accepted = 0;
  double acceptance() const { return proposals > 0 ? static_cast<double>(accepted) / static_cast<double>(proposals) : 0.0; }
};

// Every truck's latents drawn once from p(x_i | y_i, θ) (a chain of 1 + mh_steps steps per truck,
// its randomness from streams.stream(i)), with the model IFs at them (sensors x trucks).
struct TruckLatentDraws {
  std::vector<model::TruckLatent> latents;
  Eigen::MatrixXd model_if;
};
TruckLatentDraws draw_truck_latents(const site::Site& site, const fleet::MarginalTarget& target,
                                    const fleet::HyperVector& theta, const smc::RngFactory& streams, int mh_steps,
                                    MarginalDrawStats* stats = nullptr);
// The same for some of the target's trucks, all of `site` (a fit over several sites draws each
// site's trucks through their own site): columns in the order of `trucks`, truck t's randomness
// from streams.stream(t) as above.
TruckLatentDraws draw_truck_latents(const site::Site& site, const fleet::MarginalTarget& target,
                                    const fleet::HyperVector& theta, const smc::RngFactory& streams, int mh_steps,
                                    const std::vector<std::size_t>& trucks, MarginalDrawStats* stats = nullptr);
// The same under the target's model extension at ψ (its stiffness distribution in both the
// proposal and the exact target; psi null for the base model).
TruckLatentDraws draw_truck_latents(const site::Site& site, const fleet::MarginalTarget& target,
                                    const fleet::HyperVector& theta, const double* psi, const smc::RngFactory& streams,
                                    int mh_steps, const std::vector<std::size_t>& trucks,
                                    MarginalDrawStats* stats = nullptr);

// UsageError on bad options. The draws' latents are exact draws from p(x_i | y_i, θ) up to the
// MH chain's convergence from the table proposal.
PosteriorDraws posterior_draws(const site::Site& site, const fleet::MarginalSmc& fit, const MarginalDrawOptions& options,
                               MarginalDrawStats* stats = nullptr);

}  // namespace ssrfleet::discrepancy
