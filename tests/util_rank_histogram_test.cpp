// The rank machinery of simulation-based calibration (util/rank_histogram.hpp), on answers worked
// out by hand, and the whole chain (ranks, histogram, χ²) on draws whose calibration is known.
#include <cmath>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <catch2/catch.hpp>

#include "util/errors.hpp"
#include "util/rank_histogram.hpp"

using namespace ssrfleet;

TEST_CASE("the SBC rank counts the draws below the truth", "[util][sbc]") {
  const std::vector<double> draws = {0.3, 0.1, 0.7, 0.5};
  CHECK(sbc_rank(0.4, draws) == 2);
  CHECK(sbc_rank(-1.0, draws) == 0);
  CHECK(sbc_rank(1.0, draws) == 4);
  CHECK(sbc_rank(0.5, draws) == 2);  // a draw equal to the truth is not below it
}

TEST_CASE("a rank histogram joins (L + 1) / B rank values per bin", "[util][sbc]") {
  // L = 9 draws: ranks 0..9, B = 5 bins of 2 values each.
  const std::vector<int> ranks = {0, 1, 2, 3, 3, 8, 9, 9, 5};
  CHECK(rank_histogram(ranks, 9, 5) == std::vector<int>{2, 3, 1, 0, 3});
  CHECK_THROWS_AS(rank_histogram(ranks, 9, 4), UsageError);   // 4 does not divide 10
  CHECK_THROWS_AS(rank_histogram({10}, 9, 5), UsageError);    // rank above L
  CHECK_THROWS_AS(rank_histogram({-1}, 9, 5), UsageError);
}

// With B = 5 bins the statistic has 4 degrees of freedom, whose survival function is closed form:
// P(χ²(4) >= x) = exp(−x/2) (1 + x/2).
TEST_CASE("the chi-square uniformity test matches the closed form at 4 degrees of freedom", "[util][sbc]") {
  // R = 50, expected 10 per bin: (4 + 4) / 10 = 0.8.
  const ChiSquareUniformity flat = chi_square_uniformity({12, 8, 10, 10, 10});
  CHECK(flat.degrees_of_freedom == 4);
  CHECK(flat.statistic == Approx(0.8).epsilon(1e-14));
  CHECK(flat.p_value == Approx(std::exp(-0.4) * 1.4).epsilon(1e-12));  // 0.9384...
  // (100 + 25 + 25) / 10 = 15: p = 8.5 exp(−7.5) = 0.0047, a failure at the 1 % level.
  const ChiSquareUniformity lumpy = chi_square_uniformity({20, 5, 5, 10, 10});
  CHECK(lumpy.statistic == Approx(15.0).epsilon(1e-14));
  CHECK(lumpy.p_value == Approx(8.5 * std::exp(-7.5)).epsilon(1e-12));
  CHECK(lumpy.p_value < 0.01);
  // A perfectly flat histogram: statistic 0, p 1.
  CHECK(chi_square_uniformity({7, 7, 7}).p_value == Approx(1.0));
  CHECK_THROWS_AS(chi_square_uniformity({3}), UsageError);
  CHECK_THROWS_AS(chi_square_uniformity({0, 0}), UsageError);
}

// Binomial(10, 1/2): P(X <= 1) = 11/1024 = 0.0107, P(X <= 2) = 56/1024 = 0.0547; so the central 90 %
// interval (0.05 in each tail at most) is [2, 8].
TEST_CASE("the binomial central interval leaves at most the tail mass outside on each side", "[util][sbc]") {
  const CountInterval i = binomial_central_interval(10, 0.5, 0.90);
  CHECK(i.lo == 2);
  CHECK(i.hi == 8);
  // Binomial(200, 0.1), the band of a 10-bin histogram of 200 ranks (summed by hand from the
  // probability mass function): P(X <= 9) = 0.0035 <= 0.005 < P(X <= 10) and
  // P(X > 32) = 0.0029 <= 0.005 < P(X > 31), so [10, 32].
  const CountInterval band = binomial_central_interval(200, 0.1, 0.99);
  CHECK(band.lo == 10);
  CHECK(band.hi == 32);
}

namespace {
// R replications of the SBC loop with a known answer: the truth from N(0, 1), L draws from
// N(shift, scale²). shift = 0, scale = 1 is a calibrated "posterior" (the ranks are uniform).
ChiSquareUniformity toy_sbc(double shift, double scale, std::uint64_t seed) {
  constexpr int R = 1000, L = 99, B = 10;
  boost::random::mt19937_64 engine(seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  std::vector<int> ranks;
  for (int r = 0; r < R; ++r) {
    const double truth = normal(engine);
    std::vector<double> draws(L);
    for (double& d : draws) d = shift + scale * normal(engine);
    ranks.push_back(sbc_rank(truth, draws));
  }
  return chi_square_uniformity(rank_histogram(ranks, L, B));
}
}  // namespace

TEST_CASE("SBC passes calibrated draws and fails biased or too narrow ones", "[util][sbc]") {
  // Fixed seed: the calibrated case passes at 1 % (a 1-in-100 failure for a fresh seed).
  CHECK(toy_sbc(0.0, 1.0, 17).p_value > 0.01);
  // A bias of 0.3 sd, and a posterior 30 % too narrow (∪-shaped ranks): both far below 1e-6.
  CHECK(toy_sbc(0.3, 1.0, 17).p_value < 1e-6);
  CHECK(toy_sbc(0.0, 0.7, 17).p_value < 1e-6);
}
