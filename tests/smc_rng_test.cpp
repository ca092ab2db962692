// Counter-based streams: reproducible, distinct per key, uniform.
#include <catch2/catch.hpp>

#include <concepts>
#include <random>
#include <set>

#include <Eigen/Core>
#include <boost/random/normal_distribution.hpp>

#include "smc/mh_kernel.hpp"
#include "smc/parallel.hpp"
#include "smc/rng.hpp"

namespace smc = ssrfleet::smc;

static_assert(std::uniform_random_bit_generator<smc::Rng>);

TEST_CASE("a stream depends only on its keys", "[smc][rng]") {
  const smc::RngFactory root(2024);
  smc::Rng a = root.child(3, 4).stream(5), b = smc::RngFactory(2024).child(3).child(4).stream(5);
  for (int k = 0; k < 100; ++k) REQUIRE(a() == b());
  // Different particle, different step, swapped keys, different seed: different streams.
  std::set<std::uint64_t> first;
  first.insert(root.child(3, 4).stream(5)());
  first.insert(root.child(3, 4).stream(6)());
  first.insert(root.child(3, 5).stream(5)());
  first.insert(root.child(4, 3).stream(5)());
  first.insert(smc::RngFactory(2025).child(3, 4).stream(5)());
  CHECK(first.size() == 5);
}

TEST_CASE("uniform01 is uniform on the unit interval (chi-square over 20 bins)", "[smc][rng]") {
  smc::Rng rng(9);
  const int n = 200000, bins = 20;
  Eigen::ArrayXd count = Eigen::ArrayXd::Zero(bins);
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    const double u = smc::uniform01(rng);
    REQUIRE((u >= 0.0 && u < 1.0));
    count[static_cast<Eigen::Index>(u * bins)] += 1.0;
    sum += u;
  }
  const double expected = static_cast<double>(n) / bins;
  const double chi2 = ((count - expected).square() / expected).sum();
  CHECK(chi2 < 43.82);  // 0.999 quantile, 19 dof
  CHECK(sum / n == Approx(0.5).margin(5.0 * std::sqrt(1.0 / 12.0 / n)));
  // Boost.Random distributions run on it.
  boost::random::normal_distribution<double> normal;
  double s2 = 0;
  for (int k = 0; k < n; ++k) s2 += std::pow(normal(rng), 2);
  CHECK(s2 / n == Approx(1.0).margin(5.0 * std::sqrt(2.0 / n)));
}

TEST_CASE("parallel loops cover every index once and rethrow the first chunk's error", "[smc][rng]") {
  for (int threads : {1, 2, 3, 8}) {
    const smc::ParallelFor parallel(threads);
    std::vector<int> hits(101, 0);
    parallel(101, [&](Eigen::Index b, Eigen::Index e) {
      for (Eigen::Index i = b; i < e; ++i) ++hits[static_cast<std::size_t>(i)];
    });
    CHECK(std::all_of(hits.begin(), hits.end(), [](int h) { return h == 1; }));
  }
  const smc::ParallelFor parallel(3);
  CHECK_THROWS_WITH(parallel(9, [](Eigen::Index b, Eigen::Index) { throw std::runtime_error(std::to_string(b)); }),
                    "0");
  CHECK_THROWS_AS(smc::ParallelFor(0), std::invalid_argument);
}

TEST_CASE("the proposal covariance is (2.38²/d) times the weighted covariance of the cloud", "[smc][mh]") {
  Eigen::MatrixXd X(2, 3);
  X << 0.0, 1.0, 2.0,  //
      0.0, 2.0, 0.0;
  Eigen::ArrayXd W(3);
  W << 0.25, 0.5, 0.25;
  // mean (1, 1); deviations (-1,-1), (0,1), (1,-1): var x = 0.5, var y = 1, cov = 0.25·1 + 0.25·(-1) = 0.
  const Eigen::MatrixXd C = smc::weighted_covariance(X, W);
  CHECK(C(0, 0) == Approx(0.5));
  CHECK(C(1, 1) == Approx(1.0));
  CHECK(C(0, 1) == Approx(0.0).margin(1e-15));
  const Eigen::MatrixXd S = smc::proposal_covariance(X, W, 2.38);
  CHECK(S(0, 0) == Approx(2.38 * 2.38 / 2 * 0.5).epsilon(1e-9));
  CHECK(S(1, 1) == Approx(2.38 * 2.38 / 2 * 1.0).epsilon(1e-9));
  CHECK_THROWS(smc::proposal_covariance(Eigen::MatrixXd::Ones(2, 3), W, 2.38));  // collapsed cloud
}
