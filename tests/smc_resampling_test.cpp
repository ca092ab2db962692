// Each resampling scheme is unbiased: over many draws the mean number of offspring of particle i
// is M W_i, within Monte Carlo error; the multinomial scheme also passes a chi-square test.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

#include <Eigen/Core>

#include "smc/resampling.hpp"
#include "util/errors.hpp"

namespace smc = ssrfleet::smc;

namespace {
const smc::ResamplingScheme kSchemes[] = {smc::ResamplingScheme::systematic, smc::ResamplingScheme::stratified,
                                          smc::ResamplingScheme::multinomial, smc::ResamplingScheme::residual};
}

TEST_CASE("every resampling scheme gives each particle M W_i offspring on average", "[smc][resampling]") {
  Eigen::ArrayXd W(6);
  W << 0.05, 0.1, 0.2, 0.3, 0.35, 0.0;
  const Eigen::Index M = 7;  // M != P on purpose, so M W_i is not an integer
  const int draws = 20000;
  for (const auto scheme : kSchemes) {
    INFO(smc::to_string(scheme));
    smc::Rng rng(42);
    Eigen::ArrayXd count = Eigen::ArrayXd::Zero(W.size());
    for (int r = 0; r < draws; ++r) {
      const auto a = smc::resample(scheme, W, M, rng);
      REQUIRE(static_cast<Eigen::Index>(a.size()) == M);
      REQUIRE(std::is_sorted(a.begin(), a.end()));
      for (auto i : a) count[i] += 1.0;
    }
    const Eigen::ArrayXd mean = count / draws;
    for (Eigen::Index i = 0; i < W.size(); ++i) {
      // Multinomial variance M W (1 - W) bounds the others' per-draw variance (theirs is at most
      // that or 1/4, the variance of a floor/ceil choice); 5 standard errors.
      const double var = std::max(static_cast<double>(M) * W[i] * (1.0 - W[i]), W[i] > 0 ? 0.25 : 0.0);
      CHECK(std::abs(mean[i] - static_cast<double>(M) * W[i]) <= 5.0 * std::sqrt(var / draws) + 1e-12);
    }
    CHECK(count[5] == 0.0);  // a zero weight never has offspring
  }
}

TEST_CASE("multinomial resampling passes a chi-square goodness-of-fit test", "[smc][resampling]") {
  Eigen::ArrayXd W(5);
  W << 0.05, 0.15, 0.2, 0.25, 0.35;
  smc::Rng rng(7);
  const Eigen::Index M = 100;
  const int draws = 500;
  Eigen::ArrayXd count = Eigen::ArrayXd::Zero(W.size());
  for (int r = 0; r < draws; ++r)
    for (auto i : smc::multinomial_resampling(W, M, rng)) count[i] += 1.0;
  const Eigen::ArrayXd expected = W * static_cast<double>(M * draws);
  const double chi2 = ((count - expected).square() / expected).sum();
  std::cout << "multinomial resampling chi-square (4 dof): " << chi2 << "\n";
  CHECK(chi2 < 18.47);  // 0.999 quantile of chi-square with 4 degrees of freedom
}

TEST_CASE("systematic and residual schemes keep floor(M W_i) copies", "[smc][resampling]") {
  Eigen::ArrayXd W(4);
  W << 0.1, 0.4, 0.25, 0.25;
  smc::Rng rng(3);
  for (int r = 0; r < 200; ++r) {
    for (const auto scheme : {smc::ResamplingScheme::systematic, smc::ResamplingScheme::residual}) {
      const auto a = smc::resample(scheme, W, 10, rng);
      for (Eigen::Index i = 0; i < W.size(); ++i) {
        const auto n = std::count(a.begin(), a.end(), i);
        CHECK(n >= static_cast<long>(std::floor(10 * W[i] + 1e-9)));
        CHECK(n <= static_cast<long>(std::ceil(10 * W[i] - 1e-9)) + (scheme == smc::ResamplingScheme::residual ? 10 : 0));
      }
    }
  }
}

TEST_CASE("resampling is deterministic for a seed and names its schemes", "[smc][resampling]") {
  const Eigen::ArrayXd W = Eigen::ArrayXd::LinSpaced(50, 1.0, 2.0) / Eigen::ArrayXd::LinSpaced(50, 1.0, 2.0).sum();
  for (const auto scheme : kSchemes) {
    smc::Rng a(11), b(11);
    CHECK(smc::resample(scheme, W, 50, a) == smc::resample(scheme, W, 50, b));
    CHECK(smc::resampling_scheme_from_string(smc::to_string(scheme)) == scheme);
  }
  CHECK_THROWS_AS(smc::resampling_scheme_from_string("stratifed"), ssrfleet::UsageError);
  smc::Rng rng(1);
  CHECK_THROWS_AS(smc::resample(smc::ResamplingScheme::systematic, Eigen::ArrayXd::Zero(3), 3, rng),
                  ssrfleet::NumericalError);
}
