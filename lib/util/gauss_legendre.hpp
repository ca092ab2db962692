// Gauss–Legendre quadrature rules on [0, 1]: n nodes integrate polynomials of degree 2n - 1
// exactly. Nodes by Newton's method on the Legendre polynomial P_n (Abramowitz & Stegun 25.4.29).
#pragma once

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace ssrfleet::util {

struct QuadratureRule {
  std::vector<double> nodes;    // in (0, 1), increasing
  std::vector<double> weights;  // sum to 1
};

inline QuadratureRule gauss_legendre01(int n) {
  if (n < 1 || n > 200) throw std::invalid_argument("gauss_legendre01: n must be in [1, 200]");
  QuadratureRule rule;
  rule.nodes.resize(static_cast<std::size_t>(n));
  rule.weights.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    // Chebyshev-like first guess for the i-th root of P_n on [-1, 1], then Newton.
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      const double pn = n == 1 ? x : p1;
      const double pn1 = n == 1 ? 1.0 : p0;
      dp = n * (x * pn - pn1) / (x * x - 1.0);
      const double step = pn / dp;
      x -= step;
      if (std::abs(step) < 1e-16) break;
    }
    // Root x of P_n on [-1, 1] maps to (1 - x) / 2 on [0, 1] (increasing order as i grows).
    rule.nodes[static_cast<std::size_t>(i)] = 0.5 * (1.0 - x);
    rule.weights[static_cast<std::size_t>(i)] = 1.0 / ((1.0 - x * x) * dp * dp);
  }
  return rule;
}

}  // namespace ssrfleet::util
