// What the fleet posterior predicts for one truck at the sensors, given its speed and sprung mass:
// the mean impact factor at each sensor and their covariance. The truck's own
// k, k_t and z are unknown: they come from the fleet distribution, θ from the posterior
// (fleet/predictive_trucks.hpp, the same draws as the SSR prediction, with the traffic fixed to
// this truck).
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"
#include "site/site.hpp"

namespace ssrfleet::weigh {

struct PredictionSize {
  int theta_draws = 100;     // R
  int trucks_per_draw = 20;  // T
  std::uint64_t seed = 1;    // the same seed for every call: common random numbers (see the .cpp)
};

struct PredictedImpactFactors {
  Eigen::VectorXd mean;         // μ_m: mean IF at sensor m over every θ draw and truck
  Eigen::MatrixXd theta_means;  // M x R: μ_{r,m}, the mean IF under θ draw r
  // Covariance of one truck's observed IFs given θ: the spread of the model IF over the trucks of
  // a θ draw (pooled within draws) plus the sensors' noise E[σ_IF²] on the diagonal.
  Eigen::MatrixXd covariance;
};

PredictedImpactFactors predict_impact_factors(const fleet::PosteriorCloud& posterior, const site::Site& site,
                                              double speed_mps, double sprung_mass_kg, const PredictionSize& size);

}  // namespace ssrfleet::weigh
