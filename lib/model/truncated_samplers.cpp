#include "model/truncated_samplers.hpp"

#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include <boost/math/special_functions/erf.hpp>
#include <boost/math/special_functions/gamma.hpp>

namespace ssrfleet::fleet {

namespace {
constexpr double kSqrt2 = 1.41421356237309504880;

[[noreturn]] void bad_argument(const char* function, const std::string& what) {
  throw std::invalid_argument(std::string(function) + ": " + what);
}

std::string str(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

void check_u(const char* function, double u) {
  if (!(u > 0.0 && u < 1.0)) bad_argument(function, "u is " + str(u) + ", but must be in (0, 1)");
}

// Upper tail Q(t) = P(X > t) of the standard normal; exact 0 at +inf, 1 at -inf.
double upper_tail(double t) { return 0.5 * std::erfc(t / kSqrt2); }
}  // namespace

double truncated_normal_quantile(double u, double mean, double sd, double lo, double hi) {
  constexpr const char* fn = "truncated_normal_quantile";
  check_u(fn, u);
  if (!(std::isfinite(mean))) bad_argument(fn, "mean is " + str(mean) + ", but must be finite");
  if (!(std::isfinite(sd) && sd > 0.0)) bad_argument(fn, "sd is " + str(sd) + ", but must be positive");
  if (!(lo < hi)) bad_argument(fn, "interval [" + str(lo) + ", " + str(hi) + "] is empty");
  const double a = (lo - mean) / sd, b = (hi - mean) / sd;
  // The interval's mass, computed in the tail that keeps relative precision.
  double mass;
  if (a > 0.0)
    mass = upper_tail(a) - upper_tail(b);
  else if (b < 0.0)
    mass = upper_tail(-b) - upper_tail(-a);
  else
    mass = 1.0 - upper_tail(-a) - upper_tail(b);  // Phi(a) and Q(b) are both <= 1/2 here
  if (!(mass > 0.0)) {
    throw NumericalError(std::string(fn) + ": interval [" + str(lo) + ", " + str(hi) +
                         "] holds no representable mass of N(" + str(mean) + ", " + str(sd) + "^2)");
  }
  // The target point has upper tail q = Q(a) - u mass and lower tail p = Phi(a) + u mass = 1 - q;
  // invert whichever is below 1/2 (that one is computed without cancellation).
  double x;
  const double q = upper_tail(a) - u * mass;
  if (q < 0.5) {
    x = kSqrt2 * boost::math::erfc_inv(2.0 * q);
  } else {
    const double p = upper_tail(-a) + u * mass;
    x = -kSqrt2 * boost::math::erfc_inv(2.0 * p);
  }
  x = std::clamp(x, a, b);
  return std::clamp(mean + sd * x, lo, hi);
}

namespace detail {

void check_gamma_arguments(const char* function, double shape, double rate, double lo, double hi) {
  if (!(std::isfinite(shape) && shape > 0.0))
    bad_argument(function, "shape is " + str(shape) + ", but must be positive");
  if (!(std::isfinite(rate) && rate >= 0.0))
    bad_argument(function, "rate is " + str(rate) + ", but must be non-negative");
  if (!(lo >= 0.0 && lo < hi))
    bad_argument(function, "interval [" + str(lo) + ", " + str(hi) + "] must satisfy 0 <= lo < hi");
  if (rate == 0.0 && !std::isfinite(hi))
    bad_argument(function, "rate 0 needs a finite upper end (the density is improper)");
}

bool truncated_gamma_inversion(double u, double shape, double rate, double lo, double hi, double* x) {
  if (rate == 0.0) {
    // Density proportional to t^(shape-1) on [lo, hi]: CDF ((t^s - lo^s) / (hi^s - lo^s)), scaled
    // by hi^s so that no power overflows.
    const double r = std::pow(lo / hi, shape);
    *x = std::clamp(hi * std::pow(r + u * (1.0 - r), 1.0 / shape), lo, hi);
    return true;
  }
  const double xl = rate * lo, xh = rate * hi;
  const double p_lo = boost::math::gamma_p(shape, xl);
  const double q_lo = boost::math::gamma_q(shape, xl);
  const double p_hi = std::isfinite(xh) ? boost::math::gamma_p(shape, xh) : 1.0;
  const double q_hi = std::isfinite(xh) ? boost::math::gamma_q(shape, xh) : 0.0;
  double y;
  if (p_lo >= 0.5) {
    // Box above the median: invert the upper tail, which keeps precision there.
    const double mass = q_lo - q_hi;
    if (!(mass > 0.0)) return false;
    const double q = q_lo - u * mass;
    if (!(q > 0.0)) return false;
    y = boost::math::gamma_q_inv(shape, q);
  } else {
    const double mass = p_hi - p_lo;
    if (!(mass > 0.0)) return false;
    const double p = p_lo + u * mass;
    if (!(p > 0.0 && p < 1.0)) return false;
    y = boost::math::gamma_p_inv(shape, p);
  }
  *x = std::clamp(y / rate, lo, hi);
  return true;
}

}  // namespace detail

double truncated_gamma_quantile(double u, double shape, double rate, double lo, double hi) {
  constexpr const char* fn = "truncated_gamma_quantile";
  check_u(fn, u);
  detail::check_gamma_arguments(fn, shape, rate, lo, hi);
  double x = 0.0;
  if (!detail::truncated_gamma_inversion(u, shape, rate, lo, hi, &x)) {
    throw NumericalError(std::string(fn) + ": interval [" + str(lo) + ", " + str(hi) +
                         "] holds no representable mass of Gamma(" + str(shape) + ", rate " + str(rate) +
                         ")");
  }
  return x;
}

void check_scale_arguments(int n, double sum_squares, double sigma_lo, double sigma_hi) {
  constexpr const char* fn = "draw_scale_given_sum_squares";
  if (n < 2) bad_argument(fn, "n is " + std::to_string(n) + ", but must be >= 2 (Gamma shape (n-1)/2 > 0)");
  if (!(std::isfinite(sum_squares) && sum_squares >= 0.0)) {
    bad_argument(fn, "sum of squares is " + str(sum_squares) + ", but must be non-negative");
  }
  if (!(sigma_lo > 0.0 && sigma_lo < sigma_hi && std::isfinite(sigma_hi))) {
    bad_argument(fn,
                 "scale box [" + str(sigma_lo) + ", " + str(sigma_hi) + "] must satisfy 0 < lo < hi < inf");
  }
}

double scale_from_precision_quantile(double u, int n, double sum_squares, double sigma_lo, double sigma_hi) {
  check_scale_arguments(n, sum_squares, sigma_lo, sigma_hi);
  const double tau = truncated_gamma_quantile(u, 0.5 * (n - 1), 0.5 * sum_squares,
                                              1.0 / (sigma_hi * sigma_hi), 1.0 / (sigma_lo * sigma_lo));
  return std::clamp(1.0 / std::sqrt(tau), sigma_lo, sigma_hi);
}

}  // namespace ssrfleet::fleet
