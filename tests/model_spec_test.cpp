// Model specs: effects joined by '+', a parameter given is fixed, one left out is
// fitted. The composition against its components applied one after the other, and the errors.
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/simulator.hpp"
#include "model/composed_extension.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_spec.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {
const site::Site& as1() {
  static const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  return site;
}
std::vector<records::Truck> trucks() {
  return fleet::draw_fleet(fleet::FleetDistribution{}, 12, as1().lateral_min_m(), as1().lateral_max_m(), 5);
}
std::string usage_error(const std::string& spec) {
  try {
    fleet::parse_model_spec(spec, as1());
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("a model spec with one effect and nothing fixed is the catalogue's own extension", "[model][spec]") {
  CHECK(fleet::parse_model_spec("", as1()).is_base());
  CHECK(fleet::parse_model_spec("base", as1()).text == "base");
  const auto spec = fleet::parse_model_spec("tyre_damping", as1());
  REQUIRE(!spec.is_base());
  CHECK(spec.text == "tyre_damping");
  CHECK(dynamic_cast<const fleet::ComposedExtension*>(spec.extension.get()) == nullptr);
  CHECK(spec.extension->name() == "tyre_damping");
}

TEST_CASE("a composed model fits the free parameters and holds the given ones", "[model][spec]") {
  const auto spec = fleet::parse_model_spec("speed_bias+sensor_gain:sensor=11", as1());
  CHECK(spec.text == "speed_bias+sensor_gain:sensor=11");
  const fleet::ModelExtension& e = *spec.extension;
  REQUIRE(e.dim() == 2);  // speed_bias.factor and sensor_gain.gain; the sensor is fixed
  CHECK(e.parameters()[0].name == "speed_bias.factor");
  CHECK(e.parameters()[1].name == "sensor_gain.gain");
  CHECK(e.edits_forward());
  CHECK(!e.edits_stiffness_distribution());
  CHECK(e.jump_draws() == 0);
  // The canonical text parses to the same model.
  CHECK(fleet::parse_model_spec(spec.text, as1()).text == spec.text);
}

TEST_CASE("a composed model simulates as its effects applied one after the other", "[model][spec]") {
  const auto spec = fleet::parse_model_spec("speed_bias+sensor_gain:sensor=11", as1());
  const std::vector<double> psi{1.1, 1.05};  // factor, gain
  const auto composed = fleet::simulate_log(as1(), trucks(), 0.0, 1, *spec.extension, psi);
  const auto bias = fleet::parse_simulation_model("speed_bias:factor=1.1", as1());
  const auto biased = fleet::simulate_log(as1(), trucks(), 0.0, 1, *bias.extension, bias.psi);
  Eigen::ArrayXXd expected = biased.model_if;
  expected.row(10) *= 1.05;
  CHECK((composed.model_if - expected).abs().maxCoeff() < 1e-15);
  // And the same through parse_simulation_model with every parameter given.
  const auto both = fleet::parse_simulation_model("speed_bias:factor=1.1+sensor_gain:sensor=11,gain=1.05", as1());
  CHECK(both.psi.empty());
  const auto fixed = fleet::simulate_log(as1(), trucks(), 0.0, 1, *both.extension, both.psi);
  CHECK((fixed.model_if - expected).abs().maxCoeff() < 1e-15);
}

TEST_CASE("a composed model hands on its effects' jumps and move coordinates", "[model][spec]") {
  // profile_defect has a jump and its own move coordinates; tyre_damping neither.
  const auto spec = fleet::parse_model_spec("tyre_damping+profile_defect", as1());
  const fleet::ModelExtension& e = *spec.extension;
  const auto defect = fleet::make_extension("profile_defect", as1());
  const auto damping = fleet::make_extension("tyre_damping", as1());
  const auto dt = static_cast<std::size_t>(damping->dim()), dd = static_cast<std::size_t>(defect->dim());
  REQUIRE(static_cast<std::size_t>(e.dim()) == dt + dd);
  CHECK(e.jump_draws() == defect->jump_draws() + 1);
  std::vector<double> psi(dt + dd);
  for (std::size_t j = 0; j < dt; ++j) psi[j] = damping->parameters()[j].null_value;
  const std::vector<double> defect_psi{84.3, 0.5, 0.01};
  std::copy(defect_psi.begin(), defect_psi.end(), psi.begin() + static_cast<std::ptrdiff_t>(dt));
  const double u[3] = {0.2, 0.1, 0.37};
  std::vector<double> out(psi.size()), alone(dd);
  e.jump(psi.data(), u, out.data());
  defect->jump(defect_psi.data(), u + 1, alone.data());
  for (std::size_t j = 0; j < dt; ++j) CHECK(out[j] == psi[j]);
  for (std::size_t j = 0; j < dd; ++j) CHECK(out[dt + j] == alone[j]);
  std::vector<double> coords(psi.size()), defect_coords(dd), back(psi.size());
  e.to_move_coordinates(psi.data(), coords.data());
  defect->to_move_coordinates(defect_psi.data(), defect_coords.data());
  for (std::size_t j = 0; j < dd; ++j) CHECK(coords[dt + j] == defect_coords[j]);
  e.from_move_coordinates(coords.data(), back.data());
  for (std::size_t j = 0; j < psi.size(); ++j) CHECK(back[j] == Approx(psi[j]).epsilon(1e-12));
  CHECK(e.log_move_jacobian(psi.data()) == defect->log_move_jacobian(defect_psi.data()));
  // A fixed parameter turns the effect's jump off: it could move the fixed value.
  CHECK(fleet::parse_model_spec("profile_defect:length=0.5", as1()).extension->jump_draws() == 0);
}

TEST_CASE("a bad model spec is a usage error naming the bad part and listing the catalogue", "[model][spec]") {
  const auto lists_catalogue = [](const std::string& m) {
    for (const auto& name : fleet::extension_names()) {
      if (m.find("  " + name + ": ") == std::string::npos) return false;
    }
    return m.find("gain [0.8, 1.2]") != std::string::npos;
  };
  const std::string unknown = usage_error("tyre_damping+nonlinear_spring");
  CHECK_THAT(unknown, Catch::Contains("unknown effect 'nonlinear_spring'"));
  CHECK(lists_catalogue(unknown));
  const std::string param = usage_error("sensor_gain:offset=2");
  CHECK_THAT(param, Catch::Contains("'offset=2' is not param=value with param a parameter of sensor_gain"));
  CHECK(lists_catalogue(param));
  // Sensor 17 on a 16-sensor site contradicts the data.
  const std::string range = usage_error("sensor_gain:sensor=17");
  CHECK_THAT(range, Catch::Contains("sensor_gain.sensor = '17' must be a number in [0.5, 16.5]"));
  CHECK(lists_catalogue(range));
  CHECK_THAT(usage_error("sensor_gain:gain=abc"), Catch::Contains("must be a number"));
  CHECK_THAT(usage_error("speed_bias+speed_bias"), Catch::Contains("effect speed_bias is named twice"));
  CHECK_THAT(usage_error("speed_bias:factor=1.1,factor=1.2"), Catch::Contains("speed_bias.factor is given twice"));
  CHECK_THAT(usage_error("speed_bias+"), Catch::Contains("an effect has no name"));
  // A simulation needs every parameter.
  CHECK_THROWS_WITH(fleet::parse_simulation_model("speed_bias+sensor_gain:sensor=3", as1()),
                    Catch::Contains("missing: speed_bias.factor, sensor_gain.gain"));
}
