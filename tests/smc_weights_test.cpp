// Weights, ESS, conditional ESS and the evidence increment on hand-checkable numbers.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include <Eigen/Core>

#include "smc/weights.hpp"
#include "util/errors.hpp"

namespace smc = ssrfleet::smc;

TEST_CASE("log-sum-exp is stable for large and -inf log weights", "[smc][weights]") {
  Eigen::ArrayXd a(2);
  a << 1000.0, 1000.0;
  CHECK(smc::log_sum_exp(a) == Approx(1000.0 + std::log(2.0)).epsilon(1e-15));
  a << -1000.0, -std::numeric_limits<double>::infinity();
  CHECK(smc::log_sum_exp(a) == -1000.0);
  a.setConstant(-std::numeric_limits<double>::infinity());
  CHECK(smc::log_sum_exp(a) == -std::numeric_limits<double>::infinity());
  CHECK_THROWS_AS(smc::normalised_weights(a), ssrfleet::NumericalError);
}

TEST_CASE("normalised weights and ESS of hand-checkable weights", "[smc][weights]") {
  Eigen::ArrayXd logw(3);
  logw << std::log(2.0), 0.0, 0.0;  // W = (1/2, 1/4, 1/4)
  const Eigen::ArrayXd W = smc::normalised_weights(logw + 700.0);
  CHECK(W[0] == Approx(0.5));
  CHECK(W[1] == Approx(0.25));
  CHECK(smc::effective_sample_size(W) == Approx(1.0 / 0.375));  // 8/3
  CHECK(smc::effective_sample_size(Eigen::ArrayXd::Constant(10, 0.1)) == Approx(10.0));
  Eigen::ArrayXd one_hot = Eigen::ArrayXd::Zero(10);
  one_hot[3] = 1.0;
  CHECK(smc::effective_sample_size(one_hot) == Approx(1.0));
}

TEST_CASE("conditional ESS and the log mean weight increment match Zhou Johansen and Aston (2016)", "[smc][weights]") {
  Eigen::ArrayXd W(2), ll(2);
  // Equal weights: CESS equals the ESS of the new weights w = (1, 3): (1+3)²/(1+9) = 1.6.
  W << 0.5, 0.5;
  ll << 0.0, std::log(3.0);
  CHECK(smc::conditional_ess(W, ll, 1.0) == Approx(1.6));
  CHECK(smc::relative_conditional_ess(W, ll, 1.0) == Approx(0.8));
  CHECK(smc::log_mean_weight_increment(W, ll, 1.0) == Approx(std::log(2.0)));
  // Half a step: w = (1, √3).
  CHECK(smc::relative_conditional_ess(W, ll, 0.5) ==
        Approx(std::pow(0.5 * (1 + std::sqrt(3.0)), 2) / (0.5 * (1 + 3.0))));
  // Unequal weights W = (1/4, 3/4), w = (2, 1): (ΣWw)² / ΣWw² = 1.25² / 1.75.
  W << 0.25, 0.75;
  ll << std::log(2.0), 0.0;
  CHECK(smc::relative_conditional_ess(W, ll, 1.0) == Approx(1.5625 / 1.75));
  CHECK(smc::log_mean_weight_increment(W, ll, 1.0) == Approx(std::log(1.25)));
  // Invariant to a constant shift of ℓ (only the evidence increment moves, by δ·c).
  CHECK(smc::relative_conditional_ess(W, ll - 1e4, 1.0) == Approx(1.5625 / 1.75));
  CHECK(smc::log_mean_weight_increment(W, ll - 1e4, 1.0) == Approx(std::log(1.25) - 1e4));
  // δ = 0 changes nothing, even with ℓ = -inf; for δ > 0 that particle gets weight 0.
  W << 0.5, 0.5;
  ll << -std::numeric_limits<double>::infinity(), 0.0;
  CHECK(smc::relative_conditional_ess(W, ll, 0.0) == Approx(1.0));
  CHECK(smc::log_mean_weight_increment(W, ll, 0.0) == Approx(0.0).margin(1e-15));
  CHECK(smc::relative_conditional_ess(W, ll, 0.5) == Approx(0.5));
  CHECK(smc::log_mean_weight_increment(W, ll, 0.5) == Approx(std::log(0.5)));
}
