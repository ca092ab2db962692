#include "io/damage_csv.hpp"

#include <charconv>
#include <sstream>
#include <stdexcept>

namespace ssrfleet::io {

std::string power_column(double power) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, power).ptr;
  std::string name(1, 'a');  // appended, not "a" + string: GCC 12 warns falsely (-Wrestrict) on that
  name.append(buffer, end);
  return name;
}

void write_damage_csv(std::ostream& out, const records::DamageProfile& p) {
  const std::size_t n = p.position_m.size();
  if (p.powers.size() < 2 || p.powers[0].power != 1.0 || p.powers[1].power != 4.0 || p.dlc.size() != n ||
      p.hot_spot.size() != n) {
    throw std::invalid_argument("write_damage_csv: the profile must hold n = 1 and n = 4 first, one value per position");
  }
  out << "position_m,dlc";
  for (const auto& a : p.powers) {
    const std::string c = power_column(a.power);
    out << "," << c << "," << c << "_q025," << c << "_q975";
  }
  out << ",hot_spot\n";
  out.precision(10);
  for (std::size_t m = 0; m < n; ++m) {
    out << p.position_m[m] << "," << p.dlc[m];
    for (const auto& a : p.powers) out << "," << a.mean[m] << "," << a.q025[m] << "," << a.q975[m];
    out << "," << (p.hot_spot[m] ? 1 : 0) << "\n";
  }
}

std::string damage_plot_body(const std::string& csv_path, const records::DamageProfile& p) {
  std::string quoted;
  for (char c : csv_path) quoted += c == '\'' ? std::string("''") : std::string(1, c);  // gnuplot's single-quote escape
  std::ostringstream s;
  // Columns: 1 position, 2 dlc, 3-5 a1, 6-8 a4, ..., last hot_spot.
  const std::size_t hot_col = 2 + 3 * p.powers.size() + 1;
  s << "set grid lc rgb '#dddddd'\nset key outside top center horizontal\n"
    << "set title 'Damage amplification along the road (fourth-power law, posterior mean and 95 % limits)'\n"
    << "set xlabel 'position along the road (m)'\nset ylabel 'E[IF^n] (static = 1)'\n"
    << "set style fill transparent solid 0.25 noborder\n"
    << "plot '" << quoted << "' skip 1 using 1:7:8 with filledcurves lc rgb '#c0392b' title 'a_4 95 % limits', \\\n"
    << "     '' skip 1 using 1:6 with linespoints lc rgb '#c0392b' lw 2 pt 7 ps 0.5 title 'a_4 = E[IF^4]', \\\n"
    << "     '' skip 1 using 1:3 with lines lc rgb '#1f4e9c' lw 2 title 'a_1 = E[IF]', \\\n"
    << "     " << p.hot_spot_threshold << " with lines lc rgb '#7f7f7f' dt 2 title 'hot-spot threshold', \\\n"
    << "     '' skip 1 using 1:($" << hot_col << " > 0 ? $6 : NaN) with points lc rgb '#000000' pt 6 ps 1.5 title 'hot spot'\n";
  return s.str();
}

}  // namespace ssrfleet::io
