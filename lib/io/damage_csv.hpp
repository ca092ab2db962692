// The damage CSV of `ssrfleet damage`: header exactly
// position_m,dlc,a1,a1_q025,a1_q975,a4,a4_q025,a4_q975, then a{n},a{n}_q025,a{n}_q975 for each
// further power n, then hot_spot (0/1). One row per position. Formats only: damage/ computes.
#pragma once

#include <ostream>
#include <string>

#include "records/damage_profile.hpp"

namespace ssrfleet::io {

// "a4", "a2.5": the column stem of power n (shortest text that reads back to n).
std::string power_column(double power);

void write_damage_csv(std::ostream& out, const records::DamageProfile& profile);

// A gnuplot script (gnuplot_runner.hpp) that draws a_4 with its 95 % band, a_1, the hot-spot
// threshold and the hot spots along the road from the damage CSV at `csv_path`.
std::string damage_plot_body(const std::string& csv_path, const records::DamageProfile& profile);

}  // namespace ssrfleet::io
