#include <cmath>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <catch2/catch.hpp>

#include "util/effective_sample_size.hpp"

using namespace ssrfleet;

namespace {
// x_t = rho x_{t-1} + sqrt(1 - rho^2) e_t, started in its stationary law.
Eigen::VectorXd ar1_chain(double rho, Eigen::Index n, std::uint64_t seed) {
  boost::random::mt19937_64 engine(seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd x(n);
  x[0] = normal(engine);
  const double innovation = std::sqrt(1.0 - rho * rho);
  for (Eigen::Index t = 1; t < n; ++t) x[t] = rho * x[t - 1] + innovation * normal(engine);
  return x;
}
}  // namespace

TEST_CASE("the FFT autocovariance equals the direct sum", "[util][ess]") {
  const Eigen::VectorXd x = ar1_chain(0.7, 1001, 11);
  const Eigen::VectorXd acov = autocovariance(x, 50);
  const double mean = x.mean();
  for (Eigen::Index t = 0; t <= 50; ++t) {
    double direct = 0.0;
    for (Eigen::Index i = 0; i + t < x.size(); ++i) direct += (x[i] - mean) * (x[i + t] - mean);
    direct /= static_cast<double>(x.size());
    CHECK(acov[t] == Approx(direct).margin(1e-12));
  }
}

TEST_CASE("ESS of an AR(1) chain is n (1 - rho) / (1 + rho) within Monte Carlo error", "[util][ess]") {
  // The integrated autocorrelation time of AR(1) is (1 + rho) / (1 - rho). The estimator's
  // relative sd is about sqrt(2 (2M + 1) / n) for a window M of a few tau: under 5 % at the
  // sizes here, so 15 % is a > 3 sd bound.
  const Eigen::Index n = 100000;
  for (const double rho : {0.0, 0.5, 0.9, 0.95}) {
    INFO("rho = " << rho);
    const Eigen::VectorXd x = ar1_chain(rho, n, 2024 + static_cast<std::uint64_t>(100 * rho));
    const double expected = static_cast<double>(n) * (1.0 - rho) / (1.0 + rho);
    const double ess = chain_effective_sample_size(x);
    INFO("ESS " << ess << ", expected " << expected);
    CHECK(ess == Approx(expected).epsilon(0.15));
  }
}

TEST_CASE("ESS of independent draws is close to the number of draws", "[util][ess]") {
  const Eigen::VectorXd x = ar1_chain(0.0, 4000, 5);
  const double ess = chain_effective_sample_size(x);
  INFO("ESS " << ess);
  CHECK(ess == Approx(4000.0).epsilon(0.15));
}

TEST_CASE("ESS is NaN for a constant or too short chain", "[util][ess]") {
  CHECK(std::isnan(chain_effective_sample_size(Eigen::VectorXd::Constant(100, 3.0))));
  CHECK(std::isnan(chain_effective_sample_size(Eigen::VectorXd::LinSpaced(3, 0.0, 1.0))));
}
