// The distribution of truck properties across a fleet, used to simulate one. Defaults are the
// paper's Table 1 (Wilson, Harris & O'Brien): every property Gaussian, independent.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "records/truck.hpp"

namespace ssrfleet::fleet {

struct Normal {
  double mean = 0.0;
  double sd = 0.0;
};

struct FleetDistribution {
  Normal sprung_mass_kg{4450.0, 445.0};
  Normal stiffness_npm{500e3, 50e3};
  Normal tyre_stiffness_npm{1950e3, 195e3};
  Normal speed_mps{23.43, 2.08};
  Normal lateral_m{1.50, 0.50};

  // Throws UsageError naming the property unless every mean is finite (positive where physical)
  // and every sd non-negative.
  void validate() const;
};

// Draws n trucks with ids "T0001", ... Masses, stiffnesses and speeds are truncated to positive
// values and z to [lateral_min_m, lateral_max_m] (the surface), by rejection: a truck must be
// physical and must drive on the road. Deterministic for a seed on every machine (Boost.Random).
std::vector<records::Truck> draw_fleet(const FleetDistribution& dist, int n, double lateral_min_m,
                              double lateral_max_m, std::uint64_t seed);

}  // namespace ssrfleet::fleet
