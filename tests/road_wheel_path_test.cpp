// The wheel path at a lateral position (docs/model.md): linear between lines, never clamped.
#include <catch2/catch.hpp>

#include <string>

#include "road/wheel_path.hpp"

using namespace ssrfleet::road;

namespace {
Surface small_surface() {
  Surface s;
  s.dx_m = 0.05;
  s.y0_m = 0.1;
  s.dy_m = 0.05;
  s.name = "small";
  s.height_m = Eigen::ArrayXXd::Random(50, 7);
  return s;
}
}  // namespace

TEST_CASE("the wheel path on a line is that line exactly", "[road][wheel_path]") {
  const Surface s = small_surface();
  for (Eigen::Index j = 0; j < s.lines(); ++j) {
    const Eigen::ArrayXd path = wheel_path(s, s.lateral_m(j));
    CHECK((path == s.height_m.col(j)).all());
  }
}

TEST_CASE("the wheel path midway between lines is their average", "[road][wheel_path]") {
  const Surface s = small_surface();
  for (Eigen::Index j = 0; j + 1 < s.lines(); ++j) {
    const double z = s.y0_m + (static_cast<double>(j) + 0.5) * s.dy_m;
    const LateralBracket b = bracket(s, z);
    CHECK(b.line_a == j);
    CHECK(b.line_b == j + 1);
    CHECK(b.weight_b == Approx(0.5).margin(1e-12));
    const Eigen::ArrayXd expected = 0.5 * (s.height_m.col(j) + s.height_m.col(j + 1));
    CHECK((wheel_path(s, z) - expected).abs().maxCoeff() <= 1e-12);
  }
}

TEST_CASE("a wheel path outside the surface is an error naming z and the range", "[road][wheel_path]") {
  const Surface s = small_surface();
  for (const double z : {0.0999, 0.4001, -1.0, 10.0, std::nan("")}) {
    try {
      wheel_path(s, z);
      FAIL("no exception for z = " << z);
    } catch (const std::out_of_range& e) {
      const std::string what = e.what();
      CHECK_THAT(what, Catch::Contains("z = ") && Catch::Contains("0.1") && Catch::Contains("0.4"));
    }
  }
}
