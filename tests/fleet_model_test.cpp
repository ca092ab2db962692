#include <cmath>
#include <limits>

#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <catch2/catch.hpp>

#include "model/fleet_model.hpp"

using namespace ssrfleet;

namespace {
// log P(lo <= X <= hi), X ~ N(mean, sd^2), by adaptive Gauss-Kronrod quadrature of the density
// rescaled by its value at the interval's point nearest the mean, so even an interval 30 sd out
// integrates to full relative precision (the rescaling is added back in log space).
double log_mass_by_quadrature(double lo, double hi, double mean, double sd) {
  const double a = (lo - mean) / sd, b = (hi - mean) / sd;
  const double anchor = a > 0.0 ? a : (b < 0.0 ? b : 0.0);
  auto f = [&](double u) { return std::exp(-0.5 * (u * u - anchor * anchor)); };
  const double integral = boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, a, b, 15, 1e-14);
  return std::log(integral) - 0.5 * anchor * anchor - 0.5 * fleet::kLog2Pi;
}
}  // namespace

TEST_CASE("log_normal_mass agrees with quadrature to 1e-10 relative including far tails", "[fleet][model]") {
  struct Case {
    double lo, hi, mean, sd;
  };
  const Case cases[] = {{-1.0, 1.0, 0.0, 1.0},    {0.0, 5.0, 1.5, 0.5},   {0.0, 5.0, 0.2, 3.0},
                        {8.0, 9.0, 0.0, 1.0},     {-9.0, -8.0, 0.0, 1.0}, {30.0, 31.0, 0.0, 1.0},
                        {-31.0, -30.0, 0.0, 1.0}, {4.0, 4.5, 0.0, 0.5},   {0.0, 5.0, 4.8, 0.01},
                        {2.0, 2.0001, 2.0, 1.0}};
  for (const Case& c : cases) {
    INFO("[" << c.lo << ", " << c.hi << "] under N(" << c.mean << ", " << c.sd << "^2)");
    const double expected = log_mass_by_quadrature(c.lo, c.hi, c.mean, c.sd);
    const double got = fleet::log_normal_mass(c.lo, c.hi, c.mean, c.sd);
    // A relative error e in the mass is an absolute error e in its log.
    CHECK(std::abs(got - expected) < 1e-10);
  }
}

TEST_CASE("log_normal_mass of a half line matches the erfc identity", "[fleet][model]") {
  const double inf = std::numeric_limits<double>::infinity();
  // P(X > 8.5) = erfc(8.5 / sqrt 2) / 2 exactly; the same below the mean.
  CHECK(fleet::log_normal_mass(8.5, inf, 0.0, 1.0) ==
        Approx(std::log(0.5 * std::erfc(8.5 / std::sqrt(2.0)))).epsilon(1e-12));
  CHECK(fleet::log_normal_mass(-inf, -8.5, 0.0, 1.0) ==
        Approx(std::log(0.5 * std::erfc(8.5 / std::sqrt(2.0)))).epsilon(1e-12));
  CHECK(fleet::log_normal_mass(-inf, inf, 3.0, 2.0) == Approx(0.0).margin(1e-15));
}

TEST_CASE("log_latent_density integrates to one over the road's lateral range", "[fleet][model]") {
  const fleet::LateralRange range{0.0, 5.0};
  struct Case {
    double Z, sigma_z;
  };
  // Centred, wide, near each edge, narrow at an edge, and centred off the road.
  const Case cases[] = {{1.5, 0.5}, {2.5, 3.0}, {0.2, 0.5}, {4.8, 1.0}, {0.05, 0.02}, {5.3, 0.4}};
  for (const Case& c : cases) {
    INFO("Z = " << c.Z << ", sigma_z = " << c.sigma_z);
    fleet::HyperVector theta{500e3, 50e3, 1950e3, 195e3, c.Z, c.sigma_z, 0.02};
    // Hold k, kt at their means, where their densities are 1 / (sqrt(2 pi) sd) each, and
    // integrate over z.
    const double k_part =
        fleet::log_normal_density(500e3, 500e3, 50e3) + fleet::log_normal_density(1950e3, 1950e3, 195e3);
    auto f = [&](double z) {
      return std::exp(fleet::log_latent_density(500e3, 1950e3, z, theta, range) - k_part);
    };
    // Split at Z (inside the range) so the quadrature sees the peak.
    double integral = 0.0;
    if (c.Z > range.lo_m && c.Z < range.hi_m) {
      integral =
          boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, range.lo_m, c.Z, 15, 1e-13) +
          boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, c.Z, range.hi_m, 15, 1e-13);
    } else {
      integral =
          boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, range.lo_m, range.hi_m, 15, 1e-13);
    }
    CHECK(integral == Approx(1.0).epsilon(1e-9));
    // Off the road the density is zero.
    CHECK(fleet::log_latent_density(500e3, 1950e3, -0.01, theta, range) ==
          -std::numeric_limits<double>::infinity());
    CHECK(fleet::log_latent_density(500e3, 1950e3, 5.01, theta, range) ==
          -std::numeric_limits<double>::infinity());
  }
}

TEST_CASE("the hyperprior is the normalised uniform density on its box", "[fleet][model]") {
  const fleet::PriorBounds prior;
  double volume_log = 0.0;
  fleet::HyperVector centre{};
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    volume_log += std::log(prior.hi[j] - prior.lo[j]);
    centre[j] = 0.5 * (prior.lo[j] + prior.hi[j]);
  }
  // density * volume = 1 anywhere inside, edges included.
  CHECK(prior.log_prior(centre) + volume_log == Approx(0.0).margin(1e-12));
  CHECK(prior.log_prior(prior.lo) + volume_log == Approx(0.0).margin(1e-12));
  CHECK(prior.log_prior(prior.hi) + volume_log == Approx(0.0).margin(1e-12));
  CHECK(prior.contains(centre));
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    fleet::HyperVector outside = centre;
    outside[j] = prior.hi[j] * 1.0001 + 1e-12;
    INFO(fleet::kHyperNames[j]);
    CHECK(prior.log_prior(outside) == -std::numeric_limits<double>::infinity());
    CHECK_FALSE(prior.contains(outside));
  }
}

TEST_CASE("the likelihood from a sum of squared residuals is the product of Gaussian densities",
          "[fleet][model]") {
  const double residuals[] = {0.01, -0.03, 0.02, 0.0, -0.015};
  double ssr = 0.0, direct = 0.0;
  for (double r : residuals) {
    ssr += r * r;
    direct += fleet::log_normal_density(r, 0.0, 0.02);
  }
  CHECK(fleet::log_likelihood_from_ssr(ssr, 5, 0.02) == Approx(direct).epsilon(1e-13));
}
