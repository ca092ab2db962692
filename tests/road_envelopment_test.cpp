// Tyre envelopment (docs/model.md): a centred moving average whose transfer function is known.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include "road/envelopment.hpp"
#include "road/surface_generator.hpp"

using namespace ssrfleet::road;

TEST_CASE("the envelopment window has an odd number of points spanning the base length", "[road][envelopment]") {
  CHECK(envelopment_points(0.05, 0.3) == 7);
  CHECK(envelopment_points(0.05, 0.0) == 1);
  CHECK(envelopment_points(0.05, 0.02) == 1);
  CHECK_THROWS_AS(envelopment_points(0.05, -0.1), std::invalid_argument);
  CHECK_THROWS_AS(envelop(Eigen::ArrayXd::Zero(10), 0.05, -0.3), std::invalid_argument);
}

TEST_CASE("envelopment attenuates a sinusoid exactly as its transfer function says", "[road][envelopment]") {
  const double dx = 0.05;
  const double base = 0.3;
  const Eigen::Index n = 2001;
  const Eigen::Index h = (envelopment_points(dx, base) - 1) / 2;
  for (const double wavelength_m : {0.13, 0.3, 0.35, 0.5, 1.0, 3.7, 20.0}) {
    const double f = 1.0 / wavelength_m;
    const Eigen::ArrayXd x = Eigen::ArrayXd::LinSpaced(n, 0.0, dx * static_cast<double>(n - 1));
    const Eigen::ArrayXd p = 0.01 * (2.0 * std::numbers::pi * f * x + 0.3).sin();
    const Eigen::ArrayXd out = envelop(p, dx, base);
    const double gain = envelopment_gain(f, dx, base);
    // Away from the ends (the shrinking windows) the output is gain * input up to rounding: of
    // the 7-term sum (~1e-16 relative) and of the sample positions x (~1e-14 m at x = 100 m,
    // i.e. a phase error of 2 pi x_err / wavelength <= 5e-13 rad): checked at 1e-12 of the amplitude.
    const auto interior = out.segment(h, n - 2 * h) - gain * p.segment(h, n - 2 * h);
    INFO("wavelength " << wavelength_m << " m, max error / amplitude " << interior.abs().maxCoeff() / 0.01);
    CHECK(interior.abs().maxCoeff() <= 1e-12 * 0.01);
  }
  CHECK(envelopment_gain(0.0, dx, base) == 1.0);
  // First zero of the Dirichlet kernel at n = 1/(N dx).
  CHECK(std::abs(envelopment_gain(1.0 / (7 * dx), dx, base)) < 1e-15);
}

TEST_CASE("zero base length leaves the profile unchanged", "[road][envelopment]") {
  const Eigen::ArrayXd p = Eigen::ArrayXd::Random(101);
  CHECK((envelop(p, 0.05, 0.0) == p).all());
}

TEST_CASE("envelopment ends shrink symmetrically and keep the end samples", "[road][envelopment]") {
  Eigen::ArrayXd p(9);
  p << 1, 2, 4, 8, 16, 32, 64, 128, 256;
  const Eigen::ArrayXd out = envelop(p, 0.1, 0.4);  // h = 2, N = 5
  CHECK(out(0) == 1.0);
  CHECK(out(1) == Approx((1 + 2 + 4) / 3.0));
  CHECK(out(4) == Approx((4 + 8 + 16 + 32 + 64) / 5.0));
  CHECK(out(8) == 256.0);
}

TEST_CASE("enveloping a surface filters every line along travel", "[road][envelopment]") {
  SurfaceSpec spec;
  spec.length_m = 10.0;
  spec.width_m = 0.2;
  const Surface s = generate_surface(spec, 3);
  const Surface e = envelop(s, 0.3);
  REQUIRE(e.lines() == s.lines());
  for (Eigen::Index j = 0; j < s.lines(); ++j) {
    CHECK((e.height_m.col(j) == envelop(Eigen::ArrayXd(s.height_m.col(j)), s.dx_m, 0.3)).all());
  }
}
