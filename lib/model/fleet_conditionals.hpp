// The fleet model (fleet_model.hpp) over many trucks at once, from the latents' sufficient
// statistics: the log-densities of n trucks' latents given θ and the exact conditionals of θ given
// them. One place for every sampler that keeps the latents: the latent SMC core (FleetTarget's
// base density and its "theta" move) and the batch MCMC's Gibbs and MH steps call these; neither
// writes a density or a conditional of its own.
//
// With x_1..x_n ~ N(M, S²) (S uniform a priori on [lo, hi], M uniform on its box):
//   M | x, S  ~ N(Σx / n, S² / n) truncated to M's box;
//   S | x, M  : τ = 1/S² ~ Gamma((n - 1)/2, Σ(x - M)² / 2) truncated to [1/hi², 1/lo²]
// (truncated_samplers.hpp draws both exactly). The noise sd σ_IF given the residuals is the same
// scale conditional over the observations (M per truck), which a tempered stage may count in part.
#pragma once

#include <algorithm>
#include <cmath>

#include "model/fleet_model.hpp"
#include "model/truncated_samplers.hpp"

namespace ssrfleet::fleet {

// Σx and Σx² over n trucks' values of one latent.
struct LatentSums {
  double n = 0.0;
  double sum = 0.0;
  double sum2 = 0.0;
  // Σ(x - mean)², from the sums (clamped at 0 against rounding).
  double squares_about(double mean) const { return std::max(0.0, sum2 - 2.0 * mean * sum + n * mean * mean); }
};

// Σ log N(x_i | mean, sd²).
inline double log_normal_sum(const LatentSums& x, double mean, double sd) {
  const double squares = x.sum2 - 2.0 * mean * x.sum + x.n * mean * mean;
  return -0.5 * x.n * kLog2Pi - x.n * std::log(sd) - squares / (2.0 * sd * sd);
}

// Σ log N_road(z_i | Z, σ_z²): the lateral positions, each truncated to the road.
inline double log_lateral_sum(const LatentSums& z, double mean, double sd, const LateralRange& range) {
  return log_normal_sum(z, mean, sd) - z.n * log_normal_mass(range.lo_m, range.hi_m, mean, sd);
}

// Σ log N(residual | 0, σ_IF²) over `observations` residuals whose squares sum to ssr.
inline double log_noise_sum(double observations, double ssr, double sigma_if) {
  return -0.5 * observations * kLog2Pi - observations * std::log(sigma_if) - ssr / (2.0 * sigma_if * sigma_if);
}

// M | x, S on [lo, hi].
template <class Engine>
double draw_mean_given_latents(Engine& engine, const LatentSums& x, double sd, double lo, double hi) {
  return draw_truncated_normal(engine, x.sum / x.n, sd / std::sqrt(x.n), lo, hi);
}

// S | x, M on [lo, hi]; needs n >= 2.
template <class Engine>
double draw_sd_given_latents(Engine& engine, const LatentSums& x, double mean, double lo, double hi) {
  return draw_scale_given_sum_squares(engine, static_cast<int>(x.n), x.squares_about(mean), lo, hi);
}

// σ_IF | residuals on [lo, hi], over `observations` residuals (not necessarily whole: a tempered
// stage counts the newest truck's M sensors at power φ). Needs observations > 1 and ssr > 0.
template <class Engine>
double draw_noise_sd_given_ssr(Engine& engine, double observations, double ssr, double lo, double hi) {
  const double tau = draw_truncated_gamma(engine, 0.5 * (observations - 1.0), 0.5 * ssr, 1.0 / (hi * hi), 1.0 / (lo * lo));
  return std::clamp(1.0 / std::sqrt(tau), lo, hi);
}

}  // namespace ssrfleet::fleet
