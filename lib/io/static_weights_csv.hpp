// The static-weight CSVs of `ssrfleet weigh` and `ssrfleet simulate`. Formats
// only: weigh/ estimates, the simulator knows the truth.
//  - estimates: header exactly truck_id,static_kn,static_kn_q025,static_kn_q975 (static wheel load
//    and its 95 % interval, kN);
//  - the truth beside a simulated force log: truck_id,static_kn,sprung_mass_kg.
#pragma once

#include <ostream>
#include <vector>

#include "records/static_weight.hpp"
#include "records/truck.hpp"

namespace ssrfleet::io {

void write_static_weights_csv(std::ostream& out, const std::vector<records::StaticWeight>& weights);

// static_kn = (m1 + m2) g / 1000 for each truck, with the site's unsprung mass m1.
void write_true_static_weights_csv(std::ostream& out, const std::vector<records::Truck>& trucks, double unsprung_mass_kg);

}  // namespace ssrfleet::io
