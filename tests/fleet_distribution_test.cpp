#include <cmath>

#include <catch2/catch.hpp>

#include "model/fleet_distribution.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {
struct Moments {
  double mean = 0, sd = 0;
};
template <class Get>
Moments moments(const std::vector<records::Truck>& t, Get get) {
  Moments m;
  for (const auto& x : t) m.mean += get(x);
  m.mean /= static_cast<double>(t.size());
  for (const auto& x : t) m.sd += (get(x) - m.mean) * (get(x) - m.mean);
  m.sd = std::sqrt(m.sd / static_cast<double>(t.size() - 1));
  return m;
}

// Mean and sd of N(mu, s^2) truncated to [a, b] (standard formulas).
Moments truncated_normal_moments(double mu, double s, double a, double b) {
  const auto phi = [](double x) { return std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI); };
  const auto Phi = [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); };
  const double al = (a - mu) / s, be = (b - mu) / s, Z = Phi(be) - Phi(al);
  const double mean = mu + s * (phi(al) - phi(be)) / Z;
  const double var = s * s * (1 + (al * phi(al) - be * phi(be)) / Z - std::pow((phi(al) - phi(be)) / Z, 2));
  return {mean, std::sqrt(var)};
}
}  // namespace

TEST_CASE("a drawn fleet has the Table 1 means and standard deviations within Monte Carlo error", "[fleet]") {
  const int n = 20000;
  const fleet::FleetDistribution d;
  const auto trucks = fleet::draw_fleet(d, n, 0.0, 5.0, 42);
  REQUIRE(trucks.size() == static_cast<std::size_t>(n));
  const auto check = [&](const char* what, fleet::Normal target, Moments expected, Moments got) {
    INFO(what);
    // Sample mean: sd/sqrt(n); sample sd of a near-normal: sd/sqrt(2(n-1)). Allow 4.5 standard errors.
    CHECK(std::abs(got.mean - expected.mean) < 4.5 * target.sd / std::sqrt(n));
    CHECK(std::abs(got.sd - expected.sd) < 4.5 * target.sd / std::sqrt(2.0 * (n - 1)));
  };
  check("m2", d.sprung_mass_kg, {d.sprung_mass_kg.mean, d.sprung_mass_kg.sd},
        moments(trucks, [](const records::Truck& t) { return t.sprung_mass_kg; }));
  check("k", d.stiffness_npm, {d.stiffness_npm.mean, d.stiffness_npm.sd},
        moments(trucks, [](const records::Truck& t) { return t.stiffness_npm; }));
  check("kt", d.tyre_stiffness_npm, {d.tyre_stiffness_npm.mean, d.tyre_stiffness_npm.sd},
        moments(trucks, [](const records::Truck& t) { return t.tyre_stiffness_npm; }));
  check("v", d.speed_mps, {d.speed_mps.mean, d.speed_mps.sd},
        moments(trucks, [](const records::Truck& t) { return t.speed_mps; }));
  check("z", d.lateral_m, truncated_normal_moments(1.5, 0.5, 0.0, 5.0),
        moments(trucks, [](const records::Truck& t) { return t.lateral_m; }));
}

TEST_CASE("lateral positions are truncated to the road surface and the draw is reproducible", "[fleet]") {
  fleet::FleetDistribution d;
  d.lateral_m = {0.2, 1.0};  // much of the mass is off a road that starts at 0
  const auto a = fleet::draw_fleet(d, 2000, 0.0, 5.0, 7);
  for (const auto& t : a) {
    REQUIRE(t.lateral_m >= 0.0);
    REQUIRE(t.lateral_m <= 5.0);
  }
  const auto b = fleet::draw_fleet(d, 2000, 0.0, 5.0, 7);
  const auto c = fleet::draw_fleet(d, 2000, 0.0, 5.0, 8);
  CHECK(a[1999].stiffness_npm == b[1999].stiffness_npm);
  CHECK(a[1999].lateral_m == b[1999].lateral_m);
  CHECK(a[0].stiffness_npm != c[0].stiffness_npm);
  CHECK(a.front().truck_id == "T0001");
}

TEST_CASE("a fleet distribution with an impossible value is refused with its name", "[fleet]") {
  fleet::FleetDistribution d;
  d.stiffness_npm.sd = -1.0;
  CHECK_THROWS_WITH(fleet::draw_fleet(d, 10, 0, 5, 1), Catch::Contains("stiffness_npm"));
  d = {};
  d.lateral_m = {50.0, 0.1};  // never on a 5 m road
  CHECK_THROWS_AS(fleet::draw_fleet(d, 10, 0, 5, 1), UsageError);
  CHECK_THROWS_AS(fleet::draw_fleet(fleet::FleetDistribution{}, 0, 0, 5, 1), UsageError);
}
