// The Clopper-Pearson interval of a binomial proportion (Clopper & Pearson 1934): the exact
// central interval, from the beta quantiles, never shorter than its nominal coverage. For the
// detection and false-alarm rates of `diagnose` and the site check's.
#pragma once

#include <stdexcept>
#include <string>

#include <boost/math/distributions/beta.hpp>

namespace ssrfleet::util {

struct BinomialInterval {
  double lower = 0.0, upper = 1.0;
};

// x successes in n trials, two-sided level `confidence` (0.95: 2.5 % in each tail).
// std::invalid_argument unless 0 <= x <= n, n >= 1 and 0 < confidence < 1.
inline BinomialInterval clopper_pearson(int x, int n, double confidence = 0.95) {
  if (n < 1 || x < 0 || x > n || !(confidence > 0.0 && confidence < 1.0)) {
    throw std::invalid_argument("clopper_pearson: need 0 <= x <= n, n >= 1 and confidence in (0, 1); got x = " +
                                std::to_string(x) + ", n = " + std::to_string(n));
  }
  const double tail = 0.5 * (1.0 - confidence);
  BinomialInterval out;
  if (x > 0) out.lower = boost::math::quantile(boost::math::beta_distribution<>(x, n - x + 1), tail);
  if (x < n) out.upper = boost::math::quantile(boost::math::beta_distribution<>(x + 1, n - x), 1.0 - tail);
  return out;
}

}  // namespace ssrfleet::util
