#include "discrepancy/fit_draws.hpp"

#include "discrepancy/posterior_draws.hpp"

namespace ssrfleet::discrepancy {

PosteriorDraws posterior_draws(const site::Site& site, const fleet::OnlineFit& fit, const MarginalDrawOptions& options) {
  return fleet::visit_core(
      fit,
      [&](const fleet::FleetSmc& latent) {
        return posterior_draws(site, latent, options.draws, options.seed, options.threads);
      },
      [&](const fleet::MarginalSmc& marginal) { return posterior_draws(site, marginal, options); });
}

}  // namespace ssrfleet::discrepancy
