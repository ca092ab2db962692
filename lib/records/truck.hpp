// One truck axle as the fleet model sees it (paper §3.1): what the WIM system measures (speed,
// sprung mass) and what it does not (suspension stiffness k, tyre stiffness k_t, lateral
// position z). The unsprung mass and suspension damping are the site's constants. A truck list
// (docs/site-data.md, the input of a simulation) is a std::vector<Truck>; io/truck_list_csv reads
// and writes it. Plain data: no format, no model.
#pragma once

#include <string>

namespace ssrfleet::records {

struct Truck {
  std::string truck_id;
  double speed_mps = 23.43;
  double sprung_mass_kg = 4450.0;
  double stiffness_npm = 500e3;       // k
  double tyre_stiffness_npm = 1950e3; // k_t
  double lateral_m = 1.5;             // z
  std::string vehicle_class;          // records/vehicle_class.hpp; "" = unlabelled
};

}  // namespace ssrfleet::records
