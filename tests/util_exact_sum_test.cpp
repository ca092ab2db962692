#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "util/exact_sum.hpp"

using ssrfleet::util::ExactSum;

namespace {
// Log-likelihood-like terms: magnitudes from 1e-6 to 1e4, both signs.
std::vector<double> terms(std::size_t n, unsigned seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> expo(-6.0, 4.0), u(0.0, 1.0);
  std::vector<double> x(n);
  for (auto& v : x) v = (u(g) < 0.3 ? -1.0 : 1.0) * std::pow(10.0, expo(g));
  return x;
}
}  // namespace

TEST_CASE("an exact sum has the same bits in any order and any split into partial sums", "[util][exact_sum]") {
  const std::vector<double> x = terms(10000, 7);
  ExactSum forward;
  for (double v : x) forward.add(v);
  std::vector<double> shuffled = x;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937_64(3));
  ExactSum backward;
  for (double v : shuffled) backward.add(v);
  CHECK(forward.value() == backward.value());
  // Split over 4 "ranks" round-robin, the partial sums added in word form (as the MPI reduction
  // does) in a scrambled order.
  std::vector<ExactSum> part(4);
  for (std::size_t i = 0; i < x.size(); ++i) part[i % 4].add(x[i]);
  std::uint64_t words[4][ExactSum::kWords];
  for (int r = 0; r < 4; ++r) part[static_cast<std::size_t>(r)].to_words(words[r]);
  for (int r : {2, 0, 3}) ExactSum::add_words(words[r], words[1]);
  CHECK(ExactSum::from_words(words[1]).value() == forward.value());
  // A plain double sum depends on the order: the check above is not vacuous.
  const double a = std::accumulate(x.begin(), x.end(), 0.0), b = std::accumulate(shuffled.begin(), shuffled.end(), 0.0);
  CHECK(a != b);
}

TEST_CASE("an exact sum is within its grid's rounding of the true sum", "[util][exact_sum]") {
  const std::vector<double> x = terms(5000, 11);
  ExactSum s;
  long double reference = 0.0L;
  for (double v : x) s.add(v), reference += v;
  // Each term is rounded to 2^-48 (at most 2^-49 off), the total once to a double.
  // The long double reference errs too: up to 5,000 additions of terms below 1e4, 2^-64 relative each.
  const double bound = 5000 * std::ldexp(1.0, -49) + std::abs(static_cast<double>(reference)) * std::ldexp(1.0, -52) +
                       5000 * 1e4 * std::ldexp(1.0, -63);
  CHECK(std::abs(s.value() - static_cast<double>(reference)) <= bound);
  // Negative totals and carries across the 64-bit halves: -3 × 2^40 then +2^40.
  ExactSum c;
  for (int i = 0; i < 3; ++i) c.add(-std::ldexp(1.0, 40));
  c.add(std::ldexp(1.0, 40));
  CHECK(c.value() == -std::ldexp(1.0, 41));
}

TEST_CASE("an exact sum with a -inf or vanishing term is -inf, with a NaN term (and none -inf) NaN, and a term above "
          "2^50 is refused",
          "[util][exact_sum]") {
  for (double bad : {-std::numeric_limits<double>::infinity(), -1e300}) {
    ExactSum s;
    s.add(1.5);
    s.add(bad);
    s.add(2.0);
    CHECK(s.settled());
    CHECK(s.value() == -std::numeric_limits<double>::infinity());
  }
  // A NaN term makes the sum NaN (a numerical failure stays visible) ...
  ExactSum nan, minus;
  nan.add(1.0);
  nan.add(std::numeric_limits<double>::quiet_NaN());
  CHECK_FALSE(nan.settled());
  CHECK(std::isnan(nan.value()));
  // ... but -inf wins, also across partial sums in word form: a sum that stopped at its -inf (one
  // rank's) has the bits of one that went on and met the NaN (another rank's).
  minus.add(-std::numeric_limits<double>::infinity());
  std::uint64_t a[ExactSum::kWords], b[ExactSum::kWords];
  nan.to_words(a);
  minus.to_words(b);
  ExactSum::add_words(a, b);
  CHECK(ExactSum::from_words(b).value() == -std::numeric_limits<double>::infinity());
  ExactSum big;
  CHECK_THROWS_AS(big.add(1e16), std::overflow_error);
  CHECK_THROWS_AS(big.add(std::numeric_limits<double>::infinity()), std::overflow_error);
  ExactSum fine;
  fine.add(1e15);
  fine.add(-1e15);
  CHECK(fine.value() == 0.0);
}
