// The model-extension catalogue (docs/model.md): each extension's forward model against an
// independent construction of the same physics, and the effect-setting parser.
#include <algorithm>
#include <cmath>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_01.hpp>
#include <catch2/catch.hpp>

#include "fleet/simulator.hpp"
#include "model/extended_forward.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {
std::vector<records::Truck> some_trucks(const site::Site& site, int n = 24) {
  return fleet::draw_fleet(fleet::FleetDistribution{}, n, site.lateral_min_m(), site.lateral_max_m(), 7);
}

// Largest |difference| between the extension's simulation and the plain model on `other`.
double worst_difference(const site::Site& base, const std::string& setting, const site::Site& other,
                        const std::vector<records::Truck>& trucks) {
  const auto effect = fleet::parse_extension_setting(setting, base);
  const auto with_effect = fleet::simulate_log(base, trucks, 0.0, 1, *effect.extension, effect.psi);
  const auto reference = fleet::simulate_log(other, trucks, 0.0, 1);
  return (with_effect.model_if - reference.model_if).abs().maxCoeff();
}
}  // namespace

TEST_CASE("the catalogue holds the seven canonical effects of the design", "[discrepancy][extension]") {
  const auto names = fleet::extension_names();
  for (const char* want : {"sensor_gain", "tyre_damping", "unsprung_mass", "suspension_damping", "profile_defect",
                           "speed_bias", "second_class"}) {
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

TEST_CASE("profile_defect's jump is symmetric: the mirrored draws bring psi back", "[discrepancy][extension]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto effect = fleet::parse_extension_setting("profile_defect:position=84.3,length=0.5,height=0.01", site);
  const fleet::ModelExtension& ext = *effect.extension;
  REQUIRE(ext.jump_draws() == 2);
  const auto& length = ext.parameters()[1];
  for (const double u0 : {0.1, 0.5, 0.93}) {
    const double u[2] = {u0, 0.37};
    double there[3], back[3];
    ext.jump(effect.psi.data(), u, there);
    CHECK(there[2] == -0.01);  // a bump becomes a dip
    CHECK(std::abs(there[0] - 84.3) <= 1.5);
    // The reverse move: the opposite shift, and the old length redrawn.
    const double reverse[2] = {1.0 - u0, (0.5 - length.lo) / (length.hi - length.lo)};
    ext.jump(there, reverse, back);
    CHECK(back[0] == Approx(84.3).epsilon(1e-14));
    CHECK(back[1] == Approx(0.5).epsilon(1e-14));
    CHECK(back[2] == 0.01);
  }
}

TEST_CASE("second_class: its stiffness density, CDF and draws describe one two-class fleet", "[discrepancy][extension]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto effect = fleet::parse_extension_setting("second_class:share=0.3,K2=1000000,sigma_k2=100000", site);
  const fleet::ModelExtension& ext = *effect.extension;
  const double* psi = effect.psi.data();
  const double K = 500e3, sd = 50e3;
  REQUIRE(ext.edits_stiffness_distribution());
  CHECK(!ext.edits_forward());
  // The density integrates to 1 and to the CDF (Simpson's rule on a 100 N/m grid over ±10 sd of
  // both classes: its error is far below 1e-9).
  const double lo = 0.0, step = 100.0;
  double integral = 0.0, previous = std::exp(ext.log_stiffness_density(psi, lo, K, sd));
  double worst_cdf_gap = 0.0;
  for (double k = lo; k < 2.0e6; k += step) {
    const double mid = std::exp(ext.log_stiffness_density(psi, k + 0.5 * step, K, sd));
    const double next = std::exp(ext.log_stiffness_density(psi, k + step, K, sd));
    integral += step / 6.0 * (previous + 4.0 * mid + next);
    previous = next;
    worst_cdf_gap = std::max(worst_cdf_gap, std::abs(integral - ext.stiffness_cdf(psi, k + step, K, sd)));
  }
  CHECK(integral == Approx(1.0).epsilon(1e-9));
  CHECK(worst_cdf_gap < 1e-9);
  // Draws follow the CDF: Kolmogorov-Smirnov distance of 20000 draws under its 0.1 % critical
  // value 1.95 / sqrt(n).
  boost::random::mt19937_64 engine(5);
  boost::random::uniform_01<double> uniform;
  boost::random::normal_distribution<double> normal;
  constexpr int n = 20000;
  std::vector<double> u(n);
  for (auto& v : u) {
    const double a = uniform(engine);
    v = ext.stiffness_cdf(psi, ext.draw_stiffness(psi, K, sd, a, normal(engine)), K, sd);
  }
  std::sort(u.begin(), u.end());
  double ks = 0.0;
  for (int i = 0; i < n; ++i) ks = std::max({ks, (i + 1.0) / n - u[i], u[i] - static_cast<double>(i) / n});
  CHECK(ks < 1.95 / std::sqrt(n));
  // At share 0 it is the base model's N(K, σ_k²), exactly.
  const std::vector<double> none{0.0, 1e6, 1e5};
  for (double k : {3e5, 5e5, 9e5}) {
    CHECK(ext.log_stiffness_density(none.data(), k, K, sd) == fleet::log_normal_density(k, K, sd));
    CHECK(ext.draw_stiffness(none.data(), K, sd, 0.0, 0.7) == K + sd * 0.7);
  }
}

TEST_CASE("second_class simulates a share of the trucks with the second class's stiffness", "[discrepancy][extension]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = some_trucks(site, 400);
  const auto effect = fleet::parse_extension_setting("second_class:share=0.3,K2=1000000,sigma_k2=100000", site);
  const auto mixed = fleet::simulate_log(site, trucks, 0.0, 3, *effect.extension, effect.psi);
  REQUIRE(mixed.trucks.size() == trucks.size());
  int moved = 0;
  for (std::size_t i = 0; i < trucks.size(); ++i) {
    if (mixed.trucks[i].stiffness_npm == trucks[i].stiffness_npm) continue;
    ++moved;
    // A moved truck drew k from N(1000, 100²) kN/m: above 650 kN/m (3.5 sd down) but for a 2e-4 chance.
    CHECK(mixed.trucks[i].stiffness_npm > 650e3);
  }
  // Binomial(400, 0.3): mean 120, sd 9.2; allow 4 sd.
  CHECK(std::abs(moved - 120) < 4 * 9.2);
  // Everything else is the base model, driven with the edited trucks.
  const auto plain = fleet::simulate_log(site, mixed.trucks, 0.0, 3);
  CHECK((mixed.model_if - plain.model_if).abs().maxCoeff() == 0.0);
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
