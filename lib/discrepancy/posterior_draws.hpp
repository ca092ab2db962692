// Turns a fitted fleet posterior (the SMC's weighted particles) into what the posterior
// predictive checks need: equally weighted draws of every truck's model impact factors at that
// draw's latents (and extension parameters), its lateral positions and σ_IF.
#pragma once

#include <cstdint>

#include "discrepancy/posterior_checks.hpp"
#include "fleet/fleet_smc.hpp"
#include "site/site.hpp"

namespace ssrfleet::discrepancy {

// `draws` particles chosen by systematic resampling of the weights (seeded); each costs one pass
// per truck. The fit must be in the exact regime (every truck's latents kept): DataError if not.
PosteriorDraws posterior_draws(const site::Site& site, const fleet::FleetSmc& fit, int draws, std::uint64_t seed,
                               int threads);

}  // namespace ssrfleet::discrepancy
