// Sample quantiles (Hyndman & Fan type 7, the R and NumPy default: linear between order
// statistics), for prediction limits over simulated draws.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ssrfleet {

// The p-quantile, p in [0, 1], of values already sorted ascending. Empty input is an error.
inline double sorted_quantile_type7(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) throw std::invalid_argument("quantile_type7: no values");
  const double h = (static_cast<double>(sorted.size()) - 1.0) * p;
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (h - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

// Sorts `values` in place and returns the p-quantile, p in [0, 1]. Empty input is an error.
inline double quantile_type7(std::vector<double>& values, double p) {
  std::sort(values.begin(), values.end());
  return sorted_quantile_type7(values, p);
}

// The p-quantile of a weighted sample (weights >= 0, not all 0; normalised here): type 7
// generalised. Sorted by value, point i sits at the plotting position (S_i - w_i) / (1 - w_last),
// S_i the cumulative weight, and the quantile is linear between the points around p. With equal
// weights the positions are (i - 1) / (n - 1), type 7's. A mixture of samples, each component's
// points weighing its share over its count, gives the mixture's quantile.
inline double weighted_quantile(std::vector<std::pair<double, double>> value_weight, double p) {
  if (value_weight.empty()) throw std::invalid_argument("weighted_quantile: no values");
  std::sort(value_weight.begin(), value_weight.end());
  double total = 0.0;
  for (const auto& vw : value_weight) total += vw.second;
  if (!(total > 0.0)) throw std::invalid_argument("weighted_quantile: all weights are zero");
  const std::size_t n = value_weight.size();
  const double last = value_weight.back().second / total;
  if (n == 1 || !(last < 1.0)) return value_weight.back().first;
  double before = 0.0;  // S_i - w_i
  double prev_pos = 0.0, prev_value = value_weight.front().first;
  for (std::size_t i = 0; i < n; ++i) {
    const double pos = before / (1.0 - last);
    if (pos >= p) {
      if (i == 0 || pos <= prev_pos) return value_weight[i].first;
      return prev_value + (p - prev_pos) / (pos - prev_pos) * (value_weight[i].first - prev_value);
    }
    prev_pos = pos;
    prev_value = value_weight[i].first;
    before += value_weight[i].second / total;
  }
  return value_weight.back().first;
}

}  // namespace ssrfleet
