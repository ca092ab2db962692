#include "model/fleet_distribution.hpp"

#include <cmath>
#include <cstdio>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
void check_normal(const Normal& n, const char* name, bool positive_mean) {
  if (!std::isfinite(n.mean) || (positive_mean && n.mean <= 0.0)) {
    throw UsageError(std::string("fleet distribution: mean of ") + name + " is " + std::to_string(n.mean) +
                     (positive_mean ? ", but must be positive" : ", but must be finite"));
  }
  if (!std::isfinite(n.sd) || n.sd < 0.0) {
    throw UsageError(std::string("fleet distribution: sd of ") + name + " is " + std::to_string(n.sd) +
                     ", but must be non-negative");
  }
}

// Rejection from N(mean, sd) restricted to [lo, hi]. Gives up loudly rather than loop forever
// when the interval holds (almost) no mass.
template <class Engine>
double draw_truncated(Engine& engine, const Normal& n, double lo, double hi, const char* name) {
  boost::random::normal_distribution<double> normal(n.mean, n.sd);
  for (int attempt = 0; attempt < 100000; ++attempt) {
    const double x = n.sd > 0.0 ? normal(engine) : n.mean;
    if (x >= lo && x <= hi) return x;
    if (n.sd == 0.0) break;
  }
  throw UsageError(std::string("fleet distribution: ") + name + " ~ N(" + std::to_string(n.mean) + ", " +
                   std::to_string(n.sd) + "^2) almost never falls in [" + std::to_string(lo) + ", " +
                   std::to_string(hi) + "]");
}
}  // namespace

void FleetDistribution::validate() const {
  check_normal(sprung_mass_kg, "sprung_mass_kg", true);
  check_normal(stiffness_npm, "stiffness_npm", true);
  check_normal(tyre_stiffness_npm, "tyre_stiffness_npm", true);
  check_normal(speed_mps, "speed_mps", true);
  check_normal(lateral_m, "lateral_m", false);
}

std::vector<records::Truck> draw_fleet(const FleetDistribution& dist, int n, double lateral_min_m,
                              double lateral_max_m, std::uint64_t seed) {
  dist.validate();
  if (n < 1) throw UsageError("fleet: number of trucks is " + std::to_string(n) + ", but must be at least 1");
  boost::random::mt19937_64 engine(seed);
  const double inf = HUGE_VAL;
  std::vector<records::Truck> trucks;
  trucks.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    records::Truck t;
    char id[32];
    std::snprintf(id, sizeof id, "T%04d", i + 1);
    t.truck_id = id;
    // Fixed draw order (a contract: the same seed gives the same fleet in every version that
    // keeps this order).
    t.speed_mps = draw_truncated(engine, dist.speed_mps, 1e-3, inf, "speed_mps");
    t.sprung_mass_kg = draw_truncated(engine, dist.sprung_mass_kg, 1.0, inf, "sprung_mass_kg");
    t.stiffness_npm = draw_truncated(engine, dist.stiffness_npm, 1.0, inf, "stiffness_npm");
    t.tyre_stiffness_npm = draw_truncated(engine, dist.tyre_stiffness_npm, 1.0, inf, "tyre_stiffness_npm");
    t.lateral_m = draw_truncated(engine, dist.lateral_m, lateral_min_m, lateral_max_m, "lateral_m");
    trucks.push_back(std::move(t));
  }
  return trucks;
}

}  // namespace ssrfleet::fleet
