// The bisection puts every tempering step at its conditional-ESS target, and fails loudly.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include <Eigen/Core>
#include <boost/random/normal_distribution.hpp>

#include "smc/rng.hpp"
#include "smc/tempering.hpp"
#include "smc/weights.hpp"
#include "util/errors.hpp"

namespace smc = ssrfleet::smc;
using Catch::Matchers::Contains;

TEST_CASE("tempering keeps the conditional ESS at its target", "[smc][tempering]") {
  smc::Rng rng(5);
  boost::random::normal_distribution<double> normal;
  for (double target : {0.5, 0.9, 0.99}) {
    smc::TemperingOptions options;
    options.cess_target = target;
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Index P = 200;
      Eigen::ArrayXd logw(P), ll(P);
      for (Eigen::Index i = 0; i < P; ++i) {
        logw[i] = 0.5 * normal(rng);
        ll[i] = -50.0 * std::abs(normal(rng)) - 1e3;  // a peaked increment, far from 0
      }
      const Eigen::ArrayXd W = smc::normalised_weights(logw);
      double phi = 0.0;
      int steps = 0;
      while (phi < 1.0) {
        const smc::TemperatureStep s = smc::next_temperature_step(phi, W, ll, options, "trial");
        const double achieved = smc::relative_conditional_ess(W, ll, s.delta);  // recomputed independently
        CHECK(achieved == Approx(s.relative_cess).epsilon(1e-12));
        if (s.delta < 1.0 - phi) {
          CHECK(std::abs(achieved - target) <= options.tolerance);
          CHECK(s.bisections <= options.max_bisections);
          phi += s.delta;
        } else {
          CHECK(achieved >= target);
          phi = 1.0;
        }
        ++steps;
        REQUIRE(steps < 10000);
      }
    }
  }
}

TEST_CASE("a flat increment is tempered in with one step", "[smc][tempering]") {
  const Eigen::ArrayXd W = Eigen::ArrayXd::Constant(10, 0.1);
  const smc::TemperatureStep s = smc::next_temperature_step(0.25, W, Eigen::ArrayXd::Constant(10, -3.0), {}, "flat");
  CHECK(s.delta == 0.75);
  CHECK(s.relative_cess == Approx(1.0));
  CHECK(s.bisections == 0);
}

TEST_CASE("tempering errors name the particle and the stage", "[smc][tempering]") {
  const Eigen::ArrayXd W = Eigen::ArrayXd::Constant(4, 0.25);
  Eigen::ArrayXd ll(4);
  ll << 0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), -2.0;
  CHECK_THROWS_AS(smc::next_temperature_step(0.0, W, ll, {}, "truck 17"), ssrfleet::NumericalError);
  CHECK_THROWS_WITH(smc::next_temperature_step(0.0, W, ll, {}, "truck 17"),
                    Contains("particle 2") && Contains("truck 17"));
  // Half the particles 1e15 nats worse: the step that keeps CESS at 0.9 is ~1e-16, a stall.
  ll << 0.0, -1e15, 0.0, -1e15;
  CHECK_THROWS_WITH(smc::next_temperature_step(0.0, W, ll, {}, "truck 18"),
                    Contains("stalled") && Contains("truck 18"));
  // Every particle with zero likelihood.
  ll.setConstant(-std::numeric_limits<double>::infinity());
  CHECK_THROWS_WITH(smc::next_temperature_step(0.0, W, ll, {}, "truck 19"), Contains("truck 19"));
}
