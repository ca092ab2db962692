// Sample quantiles (Hyndman & Fan type 7, the R and NumPy default: linear between order
// statistics), for prediction limits over simulated draws.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace ssrfleet {

// Sorts `values` in place and returns the p-quantile, p in [0, 1]. Empty input is an error.
inline double quantile_type7(std::vector<double>& values, double p) {
  if (values.empty()) throw std::invalid_argument("quantile_type7: no values");
  std::sort(values.begin(), values.end());
  const double h = (static_cast<double>(values.size()) - 1.0) * p;
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (h - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

}  // namespace ssrfleet
