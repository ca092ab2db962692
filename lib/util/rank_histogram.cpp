#include "util/rank_histogram.hpp"

#include <string>

#include <boost/math/distributions/binomial.hpp>
#include <boost/math/distributions/chi_squared.hpp>

#include "util/errors.hpp"

namespace ssrfleet {

int sbc_rank(double truth, const std::vector<double>& draws) {
  int rank = 0;
  for (double d : draws) rank += d < truth;
  return rank;
}

std::vector<int> rank_histogram(const std::vector<int>& ranks, int draws, int bins) {
  if (bins < 2 || draws < 1 || (draws + 1) % bins != 0) {
    throw UsageError("rank_histogram: " + std::to_string(bins) + " bins must be at least 2 and divide the " +
                     std::to_string(draws + 1) + " rank values of " + std::to_string(draws) + " draws");
  }
  const int per_bin = (draws + 1) / bins;
  std::vector<int> counts(static_cast<std::size_t>(bins), 0);
  for (int r : ranks) {
    if (r < 0 || r > draws) {
      throw UsageError("rank_histogram: rank " + std::to_string(r) + " is outside [0, " + std::to_string(draws) + "]");
    }
    ++counts[static_cast<std::size_t>(r / per_bin)];
  }
  return counts;
}

ChiSquareUniformity chi_square_uniformity(const std::vector<int>& counts) {
  if (counts.size() < 2) throw UsageError("chi_square_uniformity: needs at least 2 bins");
  long total = 0;
  for (int c : counts) {
    if (c < 0) throw UsageError("chi_square_uniformity: negative count " + std::to_string(c));
    total += c;
  }
  if (total == 0) throw UsageError("chi_square_uniformity: the histogram is empty");
  const double expected = static_cast<double>(total) / static_cast<double>(counts.size());
  ChiSquareUniformity out;
  for (int c : counts) out.statistic += (c - expected) * (c - expected) / expected;
  out.degrees_of_freedom = static_cast<int>(counts.size()) - 1;
  const boost::math::chi_squared law(out.degrees_of_freedom);
  out.p_value = boost::math::cdf(boost::math::complement(law, out.statistic));
  return out;
}

CountInterval binomial_central_interval(int n, double p, double level) {
  if (n < 0 || !(p >= 0.0 && p <= 1.0) || !(level > 0.0 && level < 1.0)) {
    throw UsageError("binomial_central_interval: needs n >= 0, p in [0, 1] and level in (0, 1)");
  }
  const double tail = 0.5 * (1.0 - level);
  const boost::math::binomial law(n, p);
  CountInterval out{0, n};
  // P(X < k) = cdf(k − 1): step k up while the mass below k + 1 still fits in the tail.
  while (out.lo < n && boost::math::cdf(law, out.lo) <= tail) ++out.lo;
  // P(X > k) = complement cdf(k): step k down while the mass above k − 1 still fits in the tail.
  while (out.hi > 0 && boost::math::cdf(boost::math::complement(law, out.hi - 1)) <= tail) --out.hi;
  return out;
}

}  // namespace ssrfleet
