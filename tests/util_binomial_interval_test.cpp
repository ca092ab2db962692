// The Clopper-Pearson interval against values computed from its definition by other means: the
// closed forms at x = 0 and x = n, and the defining tail equations at an interior x.
#include <cmath>
#include <stdexcept>

#include <boost/math/distributions/binomial.hpp>
#include <catch2/catch.hpp>

#include "util/binomial_interval.hpp"

using ssrfleet::util::clopper_pearson;

TEST_CASE("Clopper-Pearson at no success and at all successes has its closed form", "[util]") {
  // x = 0: the upper limit solves (1 - p)^n = 0.025, so p = 1 - 0.025^(1/n); x = n mirrors it.
  for (int n : {1, 20, 100, 1000}) {
    INFO("n = " << n);
    const auto none = clopper_pearson(0, n);
    CHECK(none.lower == 0.0);
    CHECK(none.upper == Approx(1.0 - std::pow(0.025, 1.0 / n)).epsilon(1e-10));
    const auto all = clopper_pearson(n, n);
    CHECK(all.upper == 1.0);
    CHECK(all.lower == Approx(std::pow(0.025, 1.0 / n)).epsilon(1e-10));
  }
  // The rule of three's exact form: 0 false alarms in 100 clean logs bound the rate by 3.6 %.
  CHECK(clopper_pearson(0, 100).upper == Approx(0.0362).margin(5e-5));
}

TEST_CASE("Clopper-Pearson limits solve the binomial tail equations", "[util]") {
  // P(X >= x | p_lo) = 0.025 and P(X <= x | p_hi) = 0.025, X ~ Binomial(n, p).
  for (auto [x, n] : {std::pair{5, 100}, std::pair{17, 20}, std::pair{1, 3}, std::pair{250, 500}}) {
    INFO(x << " of " << n);
    const auto ci = clopper_pearson(x, n);
    CHECK(ci.lower < static_cast<double>(x) / n);
    CHECK(ci.upper > static_cast<double>(x) / n);
    const boost::math::binomial_distribution<double> at_lo(n, ci.lower), at_hi(n, ci.upper);
    CHECK(boost::math::cdf(boost::math::complement(at_lo, x - 1)) == Approx(0.025).epsilon(1e-8));
    CHECK(boost::math::cdf(at_hi, x) == Approx(0.025).epsilon(1e-8));
  }
  // A wider level gives a wider interval.
  const auto ci95 = clopper_pearson(5, 100), ci99 = clopper_pearson(5, 100, 0.99);
  CHECK(ci99.lower < ci95.lower);
  CHECK(ci99.upper > ci95.upper);
}

TEST_CASE("Clopper-Pearson refuses impossible counts", "[util]") {
  CHECK_THROWS_AS(clopper_pearson(3, 2), std::invalid_argument);
  CHECK_THROWS_AS(clopper_pearson(-1, 2), std::invalid_argument);
  CHECK_THROWS_AS(clopper_pearson(0, 0), std::invalid_argument);
  CHECK_THROWS_AS(clopper_pearson(1, 2, 1.0), std::invalid_argument);
}
