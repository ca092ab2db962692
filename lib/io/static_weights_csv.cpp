#include "io/static_weights_csv.hpp"

#include <limits>

#include "vehicle/quarter_car.hpp"

namespace ssrfleet::io {

void write_static_weights_csv(std::ostream& out, const std::vector<records::StaticWeight>& weights) {
  out << "truck_id,static_kn,static_kn_q025,static_kn_q975\n";
  out.precision(10);
  for (const auto& w : weights) out << w.truck_id << "," << w.static_kn << "," << w.static_kn_q025 << "," << w.static_kn_q975 << "\n";
}

void write_true_static_weights_csv(std::ostream& out, const std::vector<records::Truck>& trucks, double unsprung_mass_kg) {
  out << "truck_id,static_kn,sprung_mass_kg\n";
  out.precision(std::numeric_limits<double>::max_digits10);
  for (const auto& t : trucks) {
    out << t.truck_id << "," << (unsprung_mass_kg + t.sprung_mass_kg) * vehicle::gravity_mps2 / 1e3 << "," << t.sprung_mass_kg
        << "\n";
  }
}

}  // namespace ssrfleet::io
