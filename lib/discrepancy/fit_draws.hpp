// Posterior draws for the checks (posterior_checks.hpp) from a fit on either core, so that a caller
// needs not know which core the model was fitted on: the latent core's particles carry every
// truck's latents and each draw is a particle (posterior_draws.hpp); the marginal core's carry θ
// alone and each truck's latents are drawn afresh from p(x_i | y_i, θ) (marginal_draws.hpp).
#pragma once

#include "discrepancy/marginal_draws.hpp"
#include "discrepancy/posterior_checks.hpp"
#include "fleet/online_fit.hpp"
#include "site/site.hpp"

namespace ssrfleet::discrepancy {

// options.draws, .seed and .threads for either core; options.mh_steps on the marginal core only.
// The errors of the core's own posterior_draws.
PosteriorDraws posterior_draws(const site::Site& site, const fleet::OnlineFit& fit, const MarginalDrawOptions& options);

}  // namespace ssrfleet::discrepancy
