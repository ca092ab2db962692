// The SSR prediction (docs/model.md): the posterior predictive distribution of impact factors
// along the road. Draw θ from the weighted posterior, trucks from the fleet distribution θ
// describes (k, k_t, z), speed and sprung mass from the observed trucks (these draws are
// fleet::draw_predictive_trucks, shared with damage and weigh), simulate, add N(0, σ_IF²).
// Reported per position: the mean IF, the 2.5 / 97.5 % prediction limits, and the 95 % credible
// band of the fleet's mean pattern (the spread of the per-θ mean over θ and over a
// Bayesian bootstrap of the observed traffic, with as little simulation noise as stratified
// sampling leaves).
// Works on any site: the one fitted, or another road (paper Fig. 9).
#pragma once

#include <cstdint>
#include <ostream>
#include <vector>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"
#include "fleet/vehicle_classes.hpp"
#include "site/site.hpp"

namespace ssrfleet::predict {

struct PredictionOptions {
  int theta_draws = 200;       // θ draws (for the band of the mean pattern)
  int trucks_per_draw = 100;   // simulated trucks per θ draw (a Latin hypercube, see the .cpp)
  bool traffic_bootstrap = true;  // weigh the observed (v, m2) by a Bayesian bootstrap per θ draw
  std::uint64_t seed = 1;

  void validate() const;  // UsageError naming the option
};

struct SsrPrediction {
  std::vector<double> position_m;
  Eigen::ArrayXd mean_if;
  Eigen::ArrayXd lower95, upper95;            // prediction limits for one truck's IF
  Eigen::ArrayXd mean_lower95, mean_upper95;  // credible band of the fleet-mean IF
};

// positions_m: where to predict (strictly increasing, on the road); empty = the site's sensors.
SsrPrediction predict_ssr(const fleet::PosteriorCloud& posterior, const site::Site& site,
                          std::vector<double> positions_m, const PredictionOptions& options);

// A mixture of vehicle classes (fleet/vehicle_classes.hpp), class c weighing shares[c] (>= 0,
// one per class; fleet::class_shares checks a user's mix). Each class's predictive trucks are
// drawn and simulated as predict_ssr does, with the seed fleet::class_seed(options.seed, label).
// The mean IF is the share-weighted mean of the classes'; the prediction limits are the quantiles
// of the mixture of the classes' predictive draws (util/quantile.hpp weighted_quantile), not an
// average of limits; the band of the mean pattern is over θ draws, draw r of the mixture being
// draw r of every class (independent posteriors), its mean the share-weighted mean. A mixture
// with one class of share > 0 is exactly that class's predict_ssr (an unlabelled posterior: the
// prediction of today).
SsrPrediction predict_ssr_mixture(const fleet::ClassPosteriors& classes, const std::vector<double>& shares,
                                  const site::Site& site, std::vector<double> positions_m,
                                  const PredictionOptions& options);

// The CSV of docs/outputs.md: position_m,mean_if,lower95,upper95,mean_lower95,mean_upper95.
void write_prediction_csv(std::ostream& out, const SsrPrediction& prediction);

}  // namespace ssrfleet::predict
