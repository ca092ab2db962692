// The model-extension catalogue (DESIGN.md §6): each extension's forward model against an
// independent construction of the same physics, and the effect-setting parser.
#include <cmath>

#include <catch2/catch.hpp>

#include "fleet/extended_forward.hpp"
#include "fleet/fleet_distribution.hpp"
#include "fleet/model_extension.hpp"
#include "fleet/simulator.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {
std::vector<fleet::Truck> some_trucks(const site::Site& site, int n = 24) {
  return fleet::draw_fleet(fleet::FleetDistribution{}, n, site.lateral_min_m(), site.lateral_max_m(), 7);
}

// Largest |difference| between the extension's simulation and the plain model on `other`.
double worst_difference(const site::Site& base, const std::string& setting, const site::Site& other,
                        const std::vector<fleet::Truck>& trucks) {
  const auto effect = fleet::parse_extension_setting(setting, base);
  const auto with_effect = fleet::simulate_log(base, trucks, 0.0, 1, *effect.extension, effect.psi);
  const auto reference = fleet::simulate_log(other, trucks, 0.0, 1);
  return (with_effect.model_if - reference.model_if).abs().maxCoeff();
}
}  // namespace

TEST_CASE("the catalogue holds the seven canonical effects of the design", "[discrepancy][extension]") {
  const auto names = fleet::extension_names();
  for (const char* want : {"sensor_gain", "tyre_damping", "unsprung_mass", "suspension_damping", "profile_defect",
                           "speed_bias"}) {
    INFO(want);
    CHECK(std::find(names.begin(), names.end(), want) != names.end());
  }
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  for (const auto& name : names) {
    const auto ext = fleet::make_extension(name, site);
    INFO(name);
    CHECK(ext->name() == name);
    CHECK(!ext->signature().empty());
    // The base model lies inside every prior: "no effect" is a value the fit can find.
    for (const auto& p : ext->parameters()) {
      CHECK(p.lo < p.hi);
      CHECK(p.null_value >= p.lo);
      CHECK(p.null_value <= p.hi);
    }
  }
}

TEST_CASE("vehicle-constant extensions equal a site built with those constants", "[discrepancy][extension]") {
  const site::SiteOptions plain;
  const site::Site base(site::load_road("AS1"), plain);
  const auto trucks = some_trucks(base);
  auto with = [&](auto change) {
    site::SiteOptions o = plain;
    change(o);
    return site::Site(site::load_road("AS1"), o);
  };
  CHECK(worst_difference(base, "tyre_damping:c_t=2000", with([](auto& o) { o.tyre_damping_nspm = 2000; }), trucks) < 1e-12);
  CHECK(worst_difference(base, "unsprung_mass:m1=600", with([](auto& o) { o.unsprung_mass_kg = 600; }), trucks) < 1e-12);
  CHECK(worst_difference(base, "suspension_damping:c_b=35000",
                         with([](auto& o) { o.suspension_damping_nspm = 35000; }), trucks) < 1e-12);
  // And the effects are not nothing: c_t = 2 kN s/m changes some IF by more than the noise floor.
  CHECK(worst_difference(base, "tyre_damping:c_t=2000", base, trucks) > 1e-3);
}

TEST_CASE("speed_bias simulates the car at the logged speed divided by the factor", "[discrepancy][extension]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  auto trucks = some_trucks(site);
  const auto effect = fleet::parse_extension_setting("speed_bias:factor=1.1", site);
  const auto biased = fleet::simulate_log(site, trucks, 0.0, 1, *effect.extension, effect.psi);
  for (auto& t : trucks) t.speed_mps /= 1.1;
  const auto slow = fleet::simulate_log(site, trucks, 0.0, 1);
  CHECK((biased.model_if - slow.model_if).abs().maxCoeff() < 1e-12);
  // The log keeps the speed the WIM system measured.
  CHECK(biased.records[0].speed_mps == Approx(trucks[0].speed_mps * 1.1).epsilon(1e-15));
}

TEST_CASE("sensor_gain scales the named sensor only", "[discrepancy][extension]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = some_trucks(site);
  const auto effect = fleet::parse_extension_setting("sensor_gain:sensor=5,gain=1.05", site);
  const auto gained = fleet::simulate_log(site, trucks, 0.0, 1, *effect.extension, effect.psi);
  const auto plain = fleet::simulate_log(site, trucks, 0.0, 1);
  Eigen::ArrayXXd expected = plain.model_if;
  expected.row(4) *= 1.05;
  CHECK((gained.model_if - expected).abs().maxCoeff() < 1e-15);
}

TEST_CASE("profile_defect equals a road with the enveloped bump added to every lateral line",
          "[discrepancy][extension]") {
  const site::SiteOptions options;
  const site::Site base(site::load_road("AS1"), options);
  road::Surface bumped = site::load_road("AS1");
  const double centre = 84.3, length = 0.5, height = 0.01;
  for (Eigen::Index j = 0; j < bumped.samples(); ++j) {
    const double u = (j * bumped.dx_m - (centre - 0.5 * length)) / length;
    if (u > 0.0 && u < 1.0) bumped.height_m.row(j) += height * 0.5 * (1.0 - std::cos(2.0 * M_PI * u));
  }
  const site::Site other(bumped, options);
  const auto trucks = some_trucks(base);
  // Linearity makes the two agree to rounding; and a 10 mm bump is a large effect.
  CHECK(worst_difference(base, "profile_defect:position=84.3,length=0.5,height=0.01", other, trucks) < 1e-9);
  CHECK(worst_difference(base, "profile_defect:position=84.3,length=0.5,height=0.01", base, trucks) > 0.02);
}

TEST_CASE("effect settings are checked: name, every parameter, ranges", "[discrepancy][extension]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  CHECK_THROWS_WITH(fleet::parse_extension_setting("wind", site), Catch::Contains("unknown model extension 'wind'") &&
                                                                      Catch::Contains("sensor_gain"));
  CHECK_THROWS_WITH(fleet::parse_extension_setting("sensor_gain:gain=1.05", site), Catch::Contains("sensor is missing"));
  CHECK_THROWS_WITH(fleet::parse_extension_setting("sensor_gain:sensor=5,gain=3", site),
                    Catch::Contains("gain must be a number in [0.8, 1.2]"));
  CHECK_THROWS_WITH(fleet::parse_extension_setting("sensor_gain:sensor=5,gain=x", site), Catch::Contains("gain"));
  CHECK_THROWS_WITH(fleet::parse_extension_setting("sensor_gain:sensor=5,sensor=6,gain=1", site),
                    Catch::Contains("given twice"));
  CHECK_THROWS_WITH(fleet::parse_extension_setting("sensor_gain:volume=5", site), Catch::Contains("NAME=VALUE"));
  CHECK_THROWS_AS(fleet::parse_extension_setting("tyre_damping:c_t=-1", site), UsageError);
}
