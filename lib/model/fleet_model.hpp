// The hierarchical fleet model of the paper (§3.1, eqs. (6)-(7)) and docs/model.md, as plain
// log-densities. Both samplers (the tempered SMC and the batch MCMC baseline) build on these;
// nothing here knows how the posterior is explored.
//
//   IF°_nm ~ N(IF_n(x_m; k_n, kt_n, m2_n, z_n, v_n), sigma_IF^2)
//   k_n ~ N(K, sigma_k^2),  kt_n ~ N(K_t, sigma_kt^2),  z_n ~ N(Z, sigma_z^2) truncated to the
//   road surface [z_lo, z_hi] (a truck drives on the road; the simulator draws it that way),
//   hyperparameters uniform over the ranges of docs/model.md.
#pragma once

#include <array>
#include <cmath>
#include <string_view>

namespace ssrfleet::fleet {

// Hyperparameter order everywhere (arrays, particle files, JSON).
enum Hyper : int { kK = 0, kSigmaK, kKt, kSigmaKt, kZ, kSigmaZ, kSigmaIf, kHyperCount };
inline constexpr std::array<std::string_view, kHyperCount> kHyperNames = {
    "K", "sigma_k", "Kt", "sigma_kt", "Z", "sigma_z", "sigma_if"};
using HyperVector = std::array<double, kHyperCount>;

// Latent variables of one truck.
enum Latent : int { kStiffness = 0, kTyreStiffness, kLateral, kLatentCount };
inline constexpr std::array<std::string_view, kLatentCount> kLatentNames = {"k", "kt", "z"};

// Proper uniform priors (the paper's are "uniform over wide ranges").
struct PriorBounds {
  HyperVector lo{1e5, 1e3, 5e5, 1e3, 0.2, 0.01, 0.001};
  HyperVector hi{2e6, 5e5, 5e6, 2e6, 4.8, 3.0, 1.0};
  // log of the normalised uniform density inside the box, -inf outside.
  double log_prior(const HyperVector& theta) const;
  bool contains(const HyperVector& theta) const;
};

// Lateral range a truck can take (the road surface's width).
struct LateralRange {
  double lo_m = 0.0;
  double hi_m = 5.0;
};

inline constexpr double kLog2Pi = 1.8378770664093454836;

inline double log_normal_density(double x, double mean, double sd) {
  const double u = (x - mean) / sd;
  return -0.5 * (kLog2Pi + u * u) - std::log(sd);
}

// Φ(x), the standard normal CDF.
inline double normal_cdf(double x) { return 0.5 * std::erfc(-x * 0.70710678118654752440); }

// log of P(lo <= X <= hi) for X ~ N(mean, sd^2), accurate in the tails.
double log_normal_mass(double lo, double hi, double mean, double sd);

// log p(k, kt, z | theta) for one truck (z truncated to the lateral range).
double log_latent_density(double stiffness_npm, double tyre_stiffness_npm, double lateral_m,
                          const HyperVector& theta, const LateralRange& range);
// The same with the k factor given as its log density (log N(k | K, sigma_k^2) in the base model, a
// model extension's stiffness density otherwise: extension_conditionals.hpp). The terms are summed
// in the base model's order, so the base density's factor gives the base density's bits.
double log_latent_density_with_stiffness_term(double log_stiffness_density, double tyre_stiffness_npm,
                                              double lateral_m, const HyperVector& theta, const LateralRange& range);

// log prod_m N(y_m; IF_m, sigma^2) from the sum of squared residuals over M sensors.
inline double log_likelihood_from_ssr(double sum_squared_residuals, int sensors, double sigma_if) {
  return -0.5 * sensors * (kLog2Pi + 2.0 * std::log(sigma_if)) -
         sum_squared_residuals / (2.0 * sigma_if * sigma_if);
}

}  // namespace ssrfleet::fleet
