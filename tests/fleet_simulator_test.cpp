#include <cmath>

#include <catch2/catch.hpp>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "road/surface_presets.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"

using namespace ssrfleet;

TEST_CASE("the Table 1 fleet on AS1 gives mean IF near 1 and an air-suspension dynamic load coefficient",
          "[fleet][simulate]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 100, site.lateral_min_m(), site.lateral_max_m(), 1);
  const auto log = fleet::simulate_log(site, trucks, 0.0, 1);
  REQUIRE(log.model_if.rows() == 16);
  REQUIRE(log.model_if.cols() == 100);
  // The sensors' mean IF over the fleet: the SSR pattern. Dynamic load on a good road is a few
  // per cent, so the pattern stays within +-0.1 of the static load.
  const Eigen::ArrayXd sensor_mean = log.model_if.rowwise().mean();
  for (Eigen::Index m = 0; m < sensor_mean.size(); ++m) {
    INFO("sensor " << m + 1);
    CHECK(std::abs(sensor_mean[m] - 1.0) < 0.1);
  }
  // Dynamic load coefficient: sd of IF over trucks and sensors. Air suspensions on good roads
  // show 0.01-0.1 (Cebon, Handbook of Vehicle-Road Interaction).
  const double mean = log.model_if.mean();
  const double dlc = std::sqrt((log.model_if - mean).square().sum() / double(log.model_if.size() - 1));
  INFO("DLC " << dlc);
  CHECK(dlc > 0.01);
  CHECK(dlc < 0.1);
  CHECK(log.lift_offs == 0);
}

TEST_CASE("noise is Gaussian with sd sigma on top of the exact model output and has its own stream", "[fleet][simulate]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 400, site.lateral_min_m(), site.lateral_max_m(), 3);
  const double sigma = 0.02;
  const auto exact = fleet::simulate_log(site, trucks, 0.0, 3);
  const auto noisy = fleet::simulate_log(site, trucks, sigma, 3);
  double sum = 0, sum2 = 0;
  long n = 0;
  for (std::size_t i = 0; i < trucks.size(); ++i) {
    REQUIRE(exact.records[i].impact_factor.isApprox(exact.model_if.col(long(i)).matrix(), 0.0));
    const Eigen::VectorXd e = noisy.records[i].impact_factor - exact.records[i].impact_factor;
    sum += e.sum();
    sum2 += e.squaredNorm();
    n += e.size();
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  CHECK(std::abs(mean) < 4.0 * sigma / std::sqrt(double(n)));
  CHECK(std::abs(sd - sigma) < 4.0 * sigma / std::sqrt(2.0 * n));
}
