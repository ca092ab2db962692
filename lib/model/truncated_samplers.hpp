// Exact draws from the two conditionals of the fleet model that stay standard once the uniform
// hyperprior box truncates them (used by the batch MCMC's Gibbs steps, batch_mcmc.hpp):
//
//  - a mean (K, K_t) given its latents: N(mean of latents, sigma^2 / N) truncated to the box;
//  - a scale (sigma_k, sigma_kt, sigma_IF) given its sum of squares S over n observations: with a
//    prior uniform on sigma (not on sigma^2), the precision tau = 1/sigma^2 has density
//    proportional to tau^((n-3)/2) exp(-S tau / 2), i.e. Gamma(shape (n-1)/2, rate S/2),
//    truncated to [1/sigma_hi^2, 1/sigma_lo^2].
//
// Both are drawn by inversion of the CDF, working in whichever tail keeps precision, so a box far
// out in a tail is still sampled exactly. The quantile functions take the uniform variate as an
// argument (deterministic, testable); the draw_* templates take any Boost.Random engine.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <boost/random/gamma_distribution.hpp>
#include <boost/random/normal_distribution.hpp>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

// A uniform variate in the open interval (0, 1) from 53 random bits: never 0 or 1, and the
// same on every platform for the same engine output (unlike std::uniform_real_distribution).
template <class Engine>
double uniform_open01(Engine& engine) {
  const std::uint64_t bits = static_cast<std::uint64_t>(engine()) >> 11;
  return (static_cast<double>(bits) + 0.5) * 0x1.0p-53;
}

// The u-quantile (0 < u < 1) of N(mean, sd^2) truncated to [lo, hi] (lo < hi, either may be
// infinite). Throws std::invalid_argument on sd <= 0 or lo >= hi, NumericalError when the
// interval holds no representable mass (further than ~37 sd out; see draw_truncated_normal).
double truncated_normal_quantile(double u, double mean, double sd, double lo, double hi);

// Marsaglia's exact tail method for a standard normal truncated to [a, b] with a >= 5: propose
// from the Rayleigh tail (density x exp(-x^2/2), inverted in closed form) and accept with
// probability a / x. Acceptance exceeds 1 - 1/a^2, so the loop is short; it works however far
// out the interval lies, where the CDF itself underflows.
template <class Engine>
double standard_normal_far_tail(Engine& engine, double a, double b);

// One draw from N(mean, sd^2) truncated to [lo, hi]: inversion, or Marsaglia's tail method when
// the interval lies beyond 8 sd on one side (inversion loses relative precision out there).
template <class Engine>
double draw_truncated_normal(Engine& engine, double mean, double sd, double lo, double hi);

// The u-quantile of Gamma(shape, rate) truncated to [lo, hi] (0 <= lo < hi <= inf, shape > 0,
// rate >= 0; rate 0 is the power law tau^(shape-1) on a finite box). Inversion through
// boost::math::gamma_p / gamma_q and their inverses, on the side of the median the box lies.
double truncated_gamma_quantile(double u, double shape, double rate, double lo, double hi);

// One draw from the truncated Gamma: inversion, or, when the box lies so far in a tail that its
// mass underflows (e.g. a scale box far from the data's spread), exact rejection from the
// tangent of the log-density at the box's end nearest the mode (needs shape >= 1, where the
// log-density is concave; NumericalError otherwise).
template <class Engine>
double draw_truncated_gamma(Engine& engine, double shape, double rate, double lo, double hi);

// sigma given a sum of squares S of n observations, sigma uniform a priori on
// [sigma_lo, sigma_hi] (0 < sigma_lo < sigma_hi): tau = 1/sigma^2 ~ Gamma((n-1)/2, S/2) truncated
// to [1/sigma_hi^2, 1/sigma_lo^2]. Requires n >= 2 (the shape must be positive).
double scale_from_precision_quantile(double u, int n, double sum_squares, double sigma_lo, double sigma_hi);
// std::invalid_argument unless n >= 2, sum_squares >= 0 and 0 < sigma_lo < sigma_hi (finite).
void check_scale_arguments(int n, double sum_squares, double sigma_lo, double sigma_hi);

template <class Engine>
double draw_scale_given_sum_squares(Engine& engine, int n, double sum_squares, double sigma_lo,
                                    double sigma_hi) {
  check_scale_arguments(n, sum_squares, sigma_lo, sigma_hi);
  const double tau = draw_truncated_gamma(engine, 0.5 * (n - 1), 0.5 * sum_squares,
                                          1.0 / (sigma_hi * sigma_hi), 1.0 / (sigma_lo * sigma_lo));
  return std::clamp(1.0 / std::sqrt(tau), sigma_lo, sigma_hi);
}

namespace detail {
// Inversion of the truncated Gamma CDF; false (x untouched) when the box's mass is not
// representable in double precision. Arguments already checked.
bool truncated_gamma_inversion(double u, double shape, double rate, double lo, double hi, double* x);
void check_gamma_arguments(const char* function, double shape, double rate, double lo, double hi);
}  // namespace detail

// ---- implementation of the templates ----

template <class Engine>
double standard_normal_far_tail(Engine& engine, double a, double b) {
  // Rayleigh tail on [a, b]: P(X > x | X > a) = exp(-(x^2 - a^2)/2); truncating at b scales u.
  const double span = b * b - a * a;  // +inf when b is infinite
  for (;;) {
    const double u = uniform_open01(engine);
    // -log(1 - u (1 - exp(-span/2))) is an Exp(1) variate truncated to [0, span/2].
    const double e = -std::log1p(-u * -std::expm1(-0.5 * span));
    const double x = std::sqrt(a * a + 2.0 * e);
    if (uniform_open01(engine) * x <= a) return x < b ? x : b;
  }
}

// How many draws from the untruncated distribution to try before inverting the CDF. The box of
// the fleet model's uniform priors rarely binds, so the first draw is nearly always inside, and
// it costs a fraction of the inversion (Boost.Math's incomplete gamma works in long double).
// Either way the draw is exact: accepted rejection draws and the inversion both follow the
// truncated law.
inline constexpr int kRejectionTries = 8;

template <class Engine>
double draw_truncated_normal(Engine& engine, double mean, double sd, double lo, double hi) {
  if (sd > 0.0 && lo < hi) {
    boost::random::normal_distribution<double> normal(mean, sd);
    for (int t = 0; t < kRejectionTries; ++t) {
      const double x = normal(engine);
      if (x >= lo && x <= hi) return x;
    }
  }
  constexpr double kFarTail = 8.0;
  if (sd > 0.0 && lo < hi) {
    const double a = (lo - mean) / sd, b = (hi - mean) / sd;
    if (a >= kFarTail) return mean + sd * standard_normal_far_tail(engine, a, b);
    if (b <= -kFarTail) return mean - sd * standard_normal_far_tail(engine, -b, -a);
  }
  return truncated_normal_quantile(uniform_open01(engine), mean, sd, lo, hi);
}

template <class Engine>
double draw_truncated_gamma(Engine& engine, double shape, double rate, double lo, double hi) {
  detail::check_gamma_arguments("draw_truncated_gamma", shape, rate, lo, hi);
  if (rate > 0.0) {
    boost::random::gamma_distribution<double> gamma(shape, 1.0 / rate);
    for (int t = 0; t < kRejectionTries; ++t) {
      const double x = gamma(engine);
      if (x >= lo && x <= hi) return x;
    }
  }
  double x = 0.0;
  if (detail::truncated_gamma_inversion(uniform_open01(engine), shape, rate, lo, hi, &x)) return x;
  if (shape < 1.0)
    throw NumericalError("draw_truncated_gamma: the box holds no representable mass and shape < 1");
  // log f(t) = (shape-1) log t - rate t is concave; the box lies wholly on one side of the mode.
  // Propose from the exponential given by the tangent at the end nearest the mode (an upper
  // bound of log f), accept with probability exp(log f - tangent).
  const double mode = (shape - 1.0) / rate;
  const bool below_mode = hi <= mode;
  const double t0 = below_mode ? hi : lo;
  const double slope = (shape - 1.0) / t0 - rate;  // > 0 below the mode, < 0 above it
  const double lambda = std::abs(slope), width = hi - lo;
  for (int attempt = 0; attempt < 1000000; ++attempt) {
    const double u = uniform_open01(engine);
    // distance from t0 into the box: Exp(lambda) truncated to [0, width]
    const double d = lambda > 0.0 ? -std::log1p(-u * -std::expm1(-lambda * width)) / lambda : u * width;
    const double t = below_mode ? hi - d : lo + d;
    const double log_ratio = (shape - 1.0) * std::log(t / t0) - rate * (t - t0) - slope * (t - t0);
    if (std::log(uniform_open01(engine)) <= log_ratio) return std::clamp(t, lo, hi);
  }
  throw NumericalError("draw_truncated_gamma: tail rejection did not accept");
}

}  // namespace ssrfleet::fleet
