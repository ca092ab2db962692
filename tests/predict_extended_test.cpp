// predict with a fitted model's effects (model/physical_effects.hpp): the
// vehicle and traffic effects change the predicted force, the sensors' calibration does not, a
// road defect stays on its road, and a replaced stiffness distribution is drawn from; damage keeps
// the same, weigh the whole model (the forces it weighs went through the sensors).
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "damage/damage_profile.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "predict/ssr_prediction.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/errors.hpp"
#include "weigh/predicted_impact_factors.hpp"

using namespace ssrfleet;

namespace {
const site::Site& as1() {
  static const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  return site;
}

// A point mass at Table 1 with the model's ψ fixed at `psi` in every draw.
fleet::PosteriorCloud cloud_with(const std::string& model, std::vector<double> psi, double speed_scale = 1.0) {
  const fleet::FleetDistribution d;
  fleet::PosteriorCloud c;
  c.method = "smc";
  Eigen::VectorXd th(fleet::kHyperCount);
  th << d.stiffness_npm.mean, d.stiffness_npm.sd, d.tyre_stiffness_npm.mean, d.tyre_stiffness_npm.sd, d.lateral_m.mean,
      d.lateral_m.sd, 0.02;
  c.theta = th.replicate(1, 6);
  c.weights = Eigen::ArrayXd::Constant(6, 1.0 / 6);
  const auto trucks = fleet::draw_fleet(d, 30, as1().lateral_min_m(), as1().lateral_max_m(), 3);
  for (const auto& t : trucks) {
    c.speed_mps.push_back(t.speed_mps * speed_scale);
    c.sprung_mass_kg.push_back(t.sprung_mass_kg);
  }
  c.site_fingerprint = as1().fingerprint();
  c.model = model;
  if (!psi.empty()) {
    c.psi = Eigen::Map<Eigen::VectorXd>(psi.data(), static_cast<Eigen::Index>(psi.size())).replicate(1, 6);
  }
  return c;
}

predict::SsrPrediction predict_on(const fleet::PosteriorCloud& c, const site::Site& site = as1()) {
  predict::PredictionOptions o;
  o.theta_draws = 6;
  o.trucks_per_draw = 40;
  o.seed = 9;
  return predict::predict_ssr(c, site, {}, o);
}

double worst(const predict::SsrPrediction& a, const predict::SsrPrediction& b) {
  return std::max((a.mean_if - b.mean_if).abs().maxCoeff(), (a.upper95 - b.upper95).abs().maxCoeff());
}
}  // namespace

TEST_CASE("predict with a speed bias drives the fleet at the true speed, logged / factor", "[predict][extension]") {
  // The same prediction as the base model's from speeds already divided by the factor.
  const auto biased = predict_on(cloud_with("speed_bias", {1.1}));
  const auto slowed = predict_on(cloud_with("base", {}, 1.0 / 1.1));
  CHECK(worst(biased, slowed) < 1e-12);
  CHECK(worst(biased, predict_on(cloud_with("base", {}))) > 1e-3);  // and it is not the base model's
}

TEST_CASE("predict leaves out a sensor's calibration gain: it is the instrument, not the force", "[predict][extension]") {
  CHECK(worst(predict_on(cloud_with("sensor_gain", {5.0, 1.1})), predict_on(cloud_with("base", {}))) == 0.0);
}

TEST_CASE("predict keeps a fitted road defect on its road and only there", "[predict][extension]") {
  const auto defect = cloud_with("profile_defect", {84.3, 0.5, 0.01});
  const auto base = cloud_with("base", {});
  CHECK(worst(predict_on(defect), predict_on(base)) > 0.01);  // a 10 mm bump at the fitted site
  const site::Site other(site::load_road("AS2"), site::SiteOptions{});
  CHECK(worst(predict_on(defect, other), predict_on(base, other)) == 0.0);
}

TEST_CASE("predict draws the stiffness from a replaced distribution", "[predict][extension]") {
  // A second class with no share is the base fleet (to rounding: the class's normal is drawn through
  // the mixture's code path, with the same truncation at zero).
  const auto none = predict_on(cloud_with("second_class", {0.0, 900e3, 50e3}));
  CHECK(worst(none, predict_on(cloud_with("base", {}))) < 1e-9);
  // Half the trucks much stiffer: another pattern.
  CHECK(worst(predict_on(cloud_with("second_class", {0.5, 900e3, 50e3})), none) > 1e-3);
}

TEST_CASE("predict refuses a posterior whose draws do not fit its model", "[predict][extension]") {
  CHECK_THROWS_WITH(predict_on(cloud_with("speed_bias", {})), Catch::Contains("has 1 free parameters"));
  CHECK_THROWS_WITH(predict_on(cloud_with("warp_drive", {1.0})), Catch::Contains("unknown effect 'warp_drive'"));
}

TEST_CASE("damage keeps what the road feels of a fitted model, as predict does", "[predict][damage][extension]") {
  damage::DamageOptions o;
  o.theta_draws = 6;
  o.trucks_per_draw = 40;
  const auto biased = damage::predict_damage(cloud_with("speed_bias", {1.1}), as1(), {}, o);
  const auto slowed = damage::predict_damage(cloud_with("base", {}, 1.0 / 1.1), as1(), {}, o);
  const auto gained = damage::predict_damage(cloud_with("sensor_gain", {5.0, 1.1}), as1(), {}, o);
  const auto base = damage::predict_damage(cloud_with("base", {}), as1(), {}, o);
  for (std::size_t m = 0; m < base.dlc.size(); ++m) {
    CHECK(biased.dlc[m] == Approx(slowed.dlc[m]).epsilon(1e-12));
    CHECK(gained.dlc[m] == base.dlc[m]);  // the instrument's gain is not the road's load
  }
  CHECK(biased.dlc != base.dlc);
}

TEST_CASE("weigh predicts the sensors with the whole fitted model, a calibration gain included", "[weigh][extension]") {
  weigh::PredictionSize size;
  size.theta_draws = 6;
  size.trucks_per_draw = 10;
  const auto gained = weigh::predict_impact_factors(cloud_with("sensor_gain", {5.0, 1.1}), as1(), 20.0, 5000.0, size);
  const auto base = weigh::predict_impact_factors(cloud_with("base", {}), as1(), 20.0, 5000.0, size);
  for (Eigen::Index m = 0; m < base.mean.size(); ++m) {
    CHECK(gained.mean[m] == Approx(base.mean[m] * (m == 4 ? 1.1 : 1.0)).epsilon(1e-12));
  }
}
