#include "model/fleet_model.hpp"

#include <limits>

namespace ssrfleet::fleet {

double PriorBounds::log_prior(const HyperVector& theta) const {
  double lp = 0.0;
  for (int j = 0; j < kHyperCount; ++j) {
    if (!(theta[j] >= lo[j] && theta[j] <= hi[j])) return -std::numeric_limits<double>::infinity();
    lp -= std::log(hi[j] - lo[j]);
  }
  return lp;
}

bool PriorBounds::contains(const HyperVector& theta) const {
  for (int j = 0; j < kHyperCount; ++j) {
    if (!(theta[j] >= lo[j] && theta[j] <= hi[j])) return false;
  }
  return true;
}

double log_normal_mass(double lo, double hi, double mean, double sd) {
  const double a = (lo - mean) / sd, b = (hi - mean) / sd;
  constexpr double inv_sqrt2 = 0.70710678118654752440;
  // Work in the tail that keeps precision: for an interval above the mean use the upper tails.
  if (a > 0.0) {
    const double qa = 0.5 * std::erfc(a * inv_sqrt2), qb = 0.5 * std::erfc(b * inv_sqrt2);
    return std::log(qa - qb);
  }
  if (b < 0.0) {
    const double pa = 0.5 * std::erfc(-a * inv_sqrt2), pb = 0.5 * std::erfc(-b * inv_sqrt2);
    return std::log(pb - pa);
  }
  return std::log1p(-0.5 * std::erfc(-a * inv_sqrt2) - 0.5 * std::erfc(b * inv_sqrt2));
}

double log_latent_density(double stiffness_npm, double tyre_stiffness_npm, double lateral_m,
                          const HyperVector& theta, const LateralRange& range) {
  return log_latent_density_with_stiffness_term(log_normal_density(stiffness_npm, theta[kK], theta[kSigmaK]),
                                                tyre_stiffness_npm, lateral_m, theta, range);
}

double log_latent_density_with_stiffness_term(double log_stiffness_density, double tyre_stiffness_npm,
                                              double lateral_m, const HyperVector& theta, const LateralRange& range) {
  if (lateral_m < range.lo_m || lateral_m > range.hi_m) return -std::numeric_limits<double>::infinity();
  return log_stiffness_density + log_normal_density(tyre_stiffness_npm, theta[kKt], theta[kSigmaKt]) +
         log_normal_density(lateral_m, theta[kZ], theta[kSigmaZ]) -
         log_normal_mass(range.lo_m, range.hi_m, theta[kZ], theta[kSigmaZ]);
}

}  // namespace ssrfleet::fleet
