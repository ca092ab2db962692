// The truck-list CSV of docs/site-data.md, the input of a simulation with known trucks:
// truck_id,speed_mps,sprung_mass_kg,k_npm,kt_npm,z_m ('#' comments, extra columns ignored), and an
// optional `class` (the truck's vehicle class; written when any truck has one).
#pragma once

#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "records/truck.hpp"

namespace ssrfleet::io {

// Reads and checks a truck list: every required column present, every value a finite number,
// ids unique, speed / mass / stiffnesses positive, z within [lateral_min_m, lateral_max_m] (the
// road surface). Any failure is a DataError naming file, line and field.
std::vector<records::Truck> read_truck_list_file(const std::string& path, double lateral_min_m,
                                               double lateral_max_m);
// The same from a stream; `source` names it in messages.
std::vector<records::Truck> read_truck_list(std::istream& in, const std::string& source, double lateral_min_m,
                                          double lateral_max_m);

// Writes trucks in the same format at full precision.
void write_truck_list(std::ostream& out, const std::vector<records::Truck>& trucks);

}  // namespace ssrfleet::io
