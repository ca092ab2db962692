// A simulated WIM log on road AS1 for the inference tests: n trucks of the Table 1 fleet
// (FleetDistribution defaults), each measured by the site's sensors with noise of sd sigma_IF.
// The trucks are kept beside the log, so a test can compare a posterior with the truth.
#pragma once

#include <cstdint>
#include <vector>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "records/truck.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"

namespace ssrfleet::test {

struct SimulatedCase {
  site::Site site{site::load_road("AS1"), site::SiteOptions{}};
  std::vector<records::Truck> trucks;
  fleet::SimulatedLog log;
  // The same seed draws the fleet and the noise, as `ssrfleet simulate --seed` does.
  SimulatedCase(int n, std::uint64_t seed, double sigma_if = 0.02) {
    trucks = fleet::draw_fleet(fleet::FleetDistribution{}, n, site.lateral_min_m(), site.lateral_max_m(), seed);
    log = fleet::simulate_log(site, trucks, sigma_if, seed);
  }
};

}  // namespace ssrfleet::test
