// The trucks of the posterior predictive (docs/model.md), drawn once for every consumer of it:
// the SSR prediction (predict/), the damage along the road (damage/) and the SSR-corrected static
// weights (weigh/). Draw θ from the weighted posterior, then per θ draw T trucks: (k, k_t, z) from
// the fleet distribution θ describes, (v, m2) from the traffic. The caller simulates them through
// its site at the positions it needs (site::Site::impact_factors_at).
#pragma once

#include <optional>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"
#include "model/model_extension.hpp"
#include "model/model_spec.hpp"
#include "vehicle/pass_integrator.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

// Where the simulated trucks' speed and sprung mass come from.
struct PredictiveTraffic {
  // The observed trucks of the posterior, each θ draw weighing them by a Bayesian bootstrap
  // (Dirichlet(1, ..., 1), Rubin 1981) when `bootstrap` is set, equally otherwise.
  bool bootstrap = true;
  // Or one truck: every simulated truck drives at this speed with this sprung mass (weigh: the
  // truck on the scale, at a trial mass). Both or neither.
  std::optional<double> speed_mps, sprung_mass_kg;

  bool fixed() const { return speed_mps.has_value(); }
};

struct PredictiveTrucks {
  int theta_draws = 0, trucks_per_draw = 0;
  std::vector<Eigen::Index> theta_index;  // the posterior draw behind each θ draw
  Eigen::ArrayXd sigma_if;                // σ_IF of each θ draw
  site::TruckBatch trucks;                // θ-draw-major: truck t of θ draw r is column r * T + t
};

// R θ draws (systematic resampling by weight: low variance) x T trucks each. The T trucks of one
// θ draw form a Latin hypercube over (observed truck, k, k_t, z): each truck keeps its exact
// distribution, but together they cover each axis evenly, so the per-θ means carry little
// simulation noise. Every draw comes from `engine`, in a fixed order, so a seed gives the same
// trucks on every platform. UsageError when the posterior holds no usable draws or when a θ
// draw's lateral distribution misses the road [lateral_min_m, lateral_max_m].
// model: the fitted model's extension (null = base); when it replaces the stiffness distribution
// (second_class), k is drawn from it with the posterior's ψ of each θ draw.
PredictiveTrucks draw_predictive_trucks(const PosteriorCloud& posterior, double lateral_min_m, double lateral_max_m,
                                        int theta_draws, int trucks_per_draw, const PredictiveTraffic& traffic,
                                        boost::random::mt19937_64& engine, const ModelExtension* model = nullptr);

// The posterior's model (its "model" spec) rebuilt on `site`: a null extension for the base model.
// UsageError when it cannot be rebuilt there or the posterior's ψ draws do not fit it.
ModelSpec posterior_model(const PosteriorCloud& posterior, const site::Site& site);

// The drawn trucks' impact factors (positions x trucks) at `integrator`'s positions on the site's
// surface (null: the site's sensors), through `extension` (null: the base model) with each θ
// draw's ψ from the posterior.
void simulate_predictive_trucks(const site::Site& site, const vehicle::PassIntegrator* integrator,
                                const PosteriorCloud& posterior, const PredictiveTrucks& drawn,
                                const ModelExtension* extension, Eigen::Ref<Eigen::ArrayXXd> if_out);

}  // namespace ssrfleet::fleet
