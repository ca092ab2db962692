// The SSR prediction's Monte Carlo, with θ known exactly (every draw the same): the predicted mean
// must be the fleet's mean; the band of the mean pattern must hold the uncertainty of the
// observed traffic mix (a Bayesian bootstrap) and next to no simulation noise.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "predict/ssr_prediction.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"

using namespace ssrfleet;

namespace {
// A posterior that is a point mass at the Table 1 fleet, with `pool` as the observed trucks.
fleet::PosteriorCloud point_mass(const fleet::FleetDistribution& d, const std::vector<records::Truck>& pool) {
  fleet::PosteriorCloud cloud;
  cloud.method = "smc";
  Eigen::VectorXd th(fleet::kHyperCount);
  th << d.stiffness_npm.mean, d.stiffness_npm.sd, d.tyre_stiffness_npm.mean, d.tyre_stiffness_npm.sd,
      d.lateral_m.mean, d.lateral_m.sd, 0.02;
  cloud.theta = th.replicate(1, 8);
  cloud.weights = Eigen::ArrayXd::Constant(8, 1.0 / 8);
  for (const auto& t : pool) {
    cloud.speed_mps.push_back(t.speed_mps);
    cloud.sprung_mass_kg.push_back(t.sprung_mass_kg);
  }
  return cloud;
}

// AS3, the roughest road, where the truck-to-truck spread s of the IF is widest. 100 observed
// trucks give the prediction its speeds and sprung masses, as in the paper's test. The reference
// drives 20000 trucks of the fleet, truck j with the speed and mass of observed truck j % 100,
// so it estimates the same expectation as the prediction, and each observed truck's own mean
// IF (over k, k_t, z) from its 200 reference trucks.
struct KnownTheta {
  static constexpr int observed_trucks = 100, reference_trucks = 20000;
  site::Site site{site::load_road("AS3"), site::SiteOptions{}};
  fleet::FleetDistribution table1;
  std::vector<records::Truck> observed;
  fleet::SimulatedLog reference;
  fleet::PosteriorCloud cloud;

  KnownTheta() {
    auto trucks = fleet::draw_fleet(table1, reference_trucks, site.lateral_min_m(), site.lateral_max_m(), 11);
    observed.assign(trucks.begin(), trucks.begin() + observed_trucks);
    for (std::size_t i = 0; i < trucks.size(); ++i) {
      trucks[i].speed_mps = observed[i % observed.size()].speed_mps;
      trucks[i].sprung_mass_kg = observed[i % observed.size()].sprung_mass_kg;
    }
    reference = fleet::simulate_log(site, trucks, 0.0, 11);
    cloud = point_mass(table1, observed);
  }
  Eigen::Index sensors() const { return reference.model_if.rows(); }
  double mean(Eigen::Index m) const { return reference.model_if.row(m).mean(); }
  double sd(Eigen::Index m) const {
    const auto row = reference.model_if.row(m);
    return std::sqrt((row - row.mean()).square().sum() / (reference_trucks - 1));
  }
  // The variance, over the observed trucks, of each one's mean IF: the between-group variance of
  // the reference less the share its 200-truck group means owe to their own sampling noise.
  double traffic_variance(Eigen::Index m) const {
    const int per_group = reference_trucks / observed_trucks;
    Eigen::ArrayXd group_mean = Eigen::ArrayXd::Zero(observed_trucks), group_sq = Eigen::ArrayXd::Zero(observed_trucks);
    for (int j = 0; j < reference_trucks; ++j) {
      const double y = reference.model_if(m, j);
      group_mean[j % observed_trucks] += y / per_group;
      group_sq[j % observed_trucks] += y * y / per_group;
    }
    const Eigen::ArrayXd within = (group_sq - group_mean.square()) * per_group / (per_group - 1);
    const double between = (group_mean - group_mean.mean()).square().mean();
    return between - within.mean() / per_group;
  }
};
}  // namespace

TEST_CASE("with theta known and the traffic fixed, the predicted mean is the fleet's and the band holds little simulation noise",
          "[predict]") {
  const KnownTheta c;
  predict::PredictionOptions options;  // the defaults: 200 θ draws x 100 trucks
  options.seed = 5;
  options.traffic_bootstrap = false;
  const auto p = predict::predict_ssr(c.cloud, c.site, {}, options);

  const double T = options.trucks_per_draw, RT = options.theta_draws * T;
  double ratio_sum = 0.0;
  for (Eigen::Index m = 0; m < c.sensors(); ++m) {
    const double mean = c.mean(m), s = c.sd(m);
    // Both means estimate the same expectation: the reference from 20000 independent trucks (sd
    // s/√20000); the prediction from 20000 stratified ones (sd at most s/√20000). Four sd of
    // the difference: a 6e-5 chance per sensor for a correct sampler.
    INFO("sensor " << m + 1 << ": predicted " << p.mean_if[m] << ", reference " << mean << ", s " << s);
    CHECK(std::abs(p.mean_if[m] - mean) <= 4.0 * s * std::sqrt(1.0 / RT + 1.0 / KnownTheta::reference_trucks));
    // Independent draws would leave a band of half-width about 1.96 s/√T (the spread of 200
    // per-θ means of T trucks each), whatever θ's uncertainty; the stratified draws must cut it
    // to well under half of that.
    ratio_sum += 0.5 * (p.mean_upper95[m] - p.mean_lower95[m]) / (1.96 * s / std::sqrt(T));
    CHECK(p.mean_lower95[m] <= p.mean_if[m]);
    CHECK(p.mean_upper95[m] >= p.mean_if[m]);
  }
  const double mean_ratio = ratio_sum / static_cast<double>(c.sensors());
  INFO("band half-width / plain Monte Carlo half-width, averaged over sensors: " << mean_ratio);
  CHECK(mean_ratio < 0.5);
}

TEST_CASE("with theta known, the band of the mean is the Bayesian bootstrap's spread of the observed traffic mix",
          "[predict]") {
  const KnownTheta c;
  predict::PredictionOptions options;
  options.seed = 5;
  // More draws than the defaults, so that neither the simulation noise left in the band nor the
  // quantiles' own error hides the bootstrap's share.
  options.theta_draws = 400;
  options.trucks_per_draw = 500;
  options.traffic_bootstrap = false;
  const auto fixed = predict::predict_ssr(c.cloud, c.site, {}, options);
  options.traffic_bootstrap = true;
  const auto boot = predict::predict_ssr(c.cloud, c.site, {}, options);

  // Under Dirichlet(1, ..., 1) weights the weighted mean of n values has variance
  // (1/(n+1)) x their population variance; that is what the bootstrap must add to the band
  // (in quadrature: it is independent of the simulation noise the band already holds).
  const double n = KnownTheta::observed_trucks;
  double added = 0.0, expected = 0.0;
  for (Eigen::Index m = 0; m < c.sensors(); ++m) {
    const double hw_fixed = 0.5 * (fixed.mean_upper95[m] - fixed.mean_lower95[m]);
    const double hw_boot = 0.5 * (boot.mean_upper95[m] - boot.mean_lower95[m]);
    added += hw_boot * hw_boot - hw_fixed * hw_fixed;
    expected += 1.96 * 1.96 * c.traffic_variance(m) / (n + 1);
    INFO("sensor " << m + 1 << ": band half-width " << hw_fixed << " -> " << hw_boot);
    // The predicted mean moves by no more than the bootstrap's own spread allows.
    CHECK(std::abs(boot.mean_if[m] - fixed.mean_if[m]) <= 4.0 * std::sqrt(c.traffic_variance(m) / (n + 1) / options.theta_draws) +
                                                               4.0 * c.sd(m) / std::sqrt(options.theta_draws * options.trucks_per_draw));
  }
  // A 95 % half-width from 400 draws is known to about 5 %, its square to about 10 %, per sensor;
  // over 16 correlated sensors, differenced, the ratio scatters by about 0.06 (seeds 1-5 gave
  // 0.91-1.06), so +-25 % is four standard errors.
  INFO("added band variance / expected, summed over sensors: " << added / expected);
  CHECK(added / expected > 0.75);
  CHECK(added / expected < 1.25);
}
