// The SSR-corrected multiple-sensor static-weight estimator (the use the seed
// paper names in its §5: "knowledge of SSR will allow this bias to be removed when estimating
// vehicle static weight").
//
// A truck's force at sensor m is F_m = P_s IF_m. Given θ, E[IF_m] = μ_m for this truck (its speed,
// its sprung mass, the fleet's k, k_t, z), so each F_m / μ_m is an unbiased reading of P_s; their
// relative errors r_m = IF_m / μ_m - 1 have covariance C~ = D⁻¹ C D⁻¹ (C the predicted IF
// covariance, D = diag(μ)), and the minimum-variance unbiased combination is
//     P^ = Σ_m w_m F_m / μ_m,   w = C~⁻¹ 1 / (1ᵀ C~⁻¹ 1),   Var(P^) = P_s² / (1ᵀ C~⁻¹ 1).
// The plain mean of the sensors is the same with μ = 1 and w = 1/M: it keeps the site's SSR bias.
//
// μ depends on the sprung mass m2 = P_s / g - m1, the unknown. We iterate to a fixed point:
// start from the plain mean, predict μ and C at that mass, re-estimate, repeat until the estimate
// moves by less than a relative tolerance. Why it converges: the map P -> P^(P) changes P only
// through μ(m2), whose sensitivity is small (a 10 % heavier truck moves μ by a few tenths of a
// percent on a road whose DLC is a few percent), so the map is a strong contraction; with common
// random numbers (predicted_impact_factors.cpp) it is also deterministic and smooth. The steps
// shrink geometrically (the tests check the ratio), typically 3-4 iterations to 1e-6.
//
// The 95 % interval adds two variances (law of total variance over θ): the estimator's own,
// P^² / (1ᵀ C~⁻¹ 1) (the truck's unknown k, k_t, z and the sensor noise), and the posterior's,
// the spread over θ draws of P^_r = Σ_m w_m F_m / μ_{r,m}. The per-θ means μ_{r,m} come from T
// trucks each, so P^_r also carries simulation noise of variance at most Var(P^) / T (independent
// draws; the stratified ones carry less): left in, it widens the interval by at most 1/(2T),
// 2.5 % at T = 20. The interval is P^ ± 1.96 sd (P^ is a weighted mean of M nearly Gaussian
// readings).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"
#include "records/force_record.hpp"
#include "records/static_weight.hpp"
#include "site/site.hpp"
#include "weigh/predicted_impact_factors.hpp"

namespace ssrfleet::weigh {

struct WeighOptions {
  PredictionSize prediction;
  double relative_tolerance = 1e-6;  // stop when a step moves the estimate by less than this fraction
  int max_iterations = 20;           // NumericalError beyond this
  double min_sprung_mass_kg = 100.0; // a lighter implied mass is a fault in the forces, not a truck (WimLimits)

  void validate() const;  // UsageError naming the option
};

// The combination for given predicted IFs: estimate, weights and the relative variance
// 1 / (1ᵀ C~⁻¹ 1). NumericalError if C~ is not positive definite.
struct CombinedSensors {
  double static_n = 0.0;
  Eigen::VectorXd weights;
  double relative_variance = 0.0;
};
CombinedSensors combine_sensors(const Eigen::VectorXd& force_n, const Eigen::VectorXd& mean_if,
                                const Eigen::MatrixXd& if_covariance);

// What the iteration did, for tests and diagnostics: the estimate after each step.
struct FixedPointTrace {
  std::vector<double> estimates_n;  // P^(0) (plain mean), P^(1), ...
};

// One truck. DataError (the record's line, field force_1) when its forces imply a sprung mass
// below min_sprung_mass_kg; NumericalError when the iteration does not converge.
records::StaticWeight estimate_static_weight(const fleet::PosteriorCloud& posterior, const site::Site& site,
                                             const records::ForceRecord& record, const std::string& source_name,
                                             const WeighOptions& options, FixedPointTrace* trace = nullptr);

}  // namespace ssrfleet::weigh
