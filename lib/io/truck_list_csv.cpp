#include "io/truck_list_csv.hpp"

#include <algorithm>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_set>

#include "io/csv_reader.hpp"
#include "records/vehicle_class.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

std::vector<records::Truck> read_truck_list_file(const std::string& path, double lateral_min_m,
                                               double lateral_max_m) {
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open truck list '" + path + "'");
  return read_truck_list(in, path, lateral_min_m, lateral_max_m);
}

std::vector<records::Truck> read_truck_list(std::istream& in, const std::string& path, double lateral_min_m,
                                          double lateral_max_m) {
  CsvReader csv(in, path);
  CsvRow row;
  if (!csv.next(row)) throw DataError(path, 1, "header", "empty file: no header line");
  const std::vector<std::string> header = row.fields;
  const std::size_t header_line = row.line;
  const char* names[] = {"truck_id", "speed_mps", "sprung_mass_kg", "k_npm", "kt_npm", "z_m"};
  long col[6];
  for (int i = 0; i < 6; ++i) {
    col[i] = column_index(header, names[i]);
    if (col[i] < 0) throw DataError(path, header_line, names[i], "required column is missing from the header");
  }
  const long class_col = column_index(header, "class");  // optional: the trucks' vehicle classes
  std::vector<records::Truck> trucks;
  std::unordered_set<std::string> ids;
  while (csv.next(row)) {
    if (row.fields.size() != header.size()) {
      throw DataError(path, row.line, "columns",
                      "row has " + std::to_string(row.fields.size()) + " fields but the header has " +
                          std::to_string(header.size()));
    }
    const auto field = [&](int i) { return row.fields[static_cast<std::size_t>(col[i])]; };
    const auto positive = [&](int i) {
      const double v = parse_finite(field(i), path, row.line, names[i]);
      if (v <= 0.0) throw DataError(path, row.line, names[i], "value " + field(i) + " must be positive");
      return v;
    };
    records::Truck t;
    t.truck_id = field(0);
    if (t.truck_id.empty()) throw DataError(path, row.line, "truck_id", "empty truck_id");
    if (!ids.insert(t.truck_id).second) throw DataError(path, row.line, "truck_id", "duplicate truck_id '" + t.truck_id + "'");
    t.speed_mps = positive(1);
    t.sprung_mass_kg = positive(2);
    t.stiffness_npm = positive(3);
    t.tyre_stiffness_npm = positive(4);
    t.lateral_m = parse_finite(field(5), path, row.line, "z_m");
    if (t.lateral_m < lateral_min_m || t.lateral_m > lateral_max_m) {
      std::ostringstream os;
      os << "lateral position " << field(5) << " m is outside the road surface [" << lateral_min_m << ", "
         << lateral_max_m << "] m";
      throw DataError(path, row.line, "z_m", os.str());
    }
    if (class_col >= 0) {
      t.vehicle_class = row.fields[static_cast<std::size_t>(class_col)];
      if (!records::is_class_label(t.vehicle_class)) {
        throw DataError(path, row.line, "class",
                        "class label '" + t.vehicle_class + "' is not a label (one or more of A-Z a-z 0-9 _ . -)");
      }
    }
    trucks.push_back(std::move(t));
  }
  if (trucks.empty()) throw DataError(path, header_line + 1, "truck_id", "the truck list holds no trucks");
  return trucks;
}

void write_truck_list(std::ostream& out, const std::vector<records::Truck>& trucks) {
  const bool with_class =
      std::any_of(trucks.begin(), trucks.end(), [](const records::Truck& t) { return !t.vehicle_class.empty(); });
  out << "truck_id,speed_mps,sprung_mass_kg,k_npm,kt_npm,z_m" << (with_class ? ",class" : "") << "\n";
  out.precision(std::numeric_limits<double>::max_digits10);
  for (const auto& t : trucks) {
    out << t.truck_id << "," << t.speed_mps << "," << t.sprung_mass_kg << "," << t.stiffness_npm << ","
        << t.tyre_stiffness_npm << "," << t.lateral_m;
    if (with_class) out << "," << t.vehicle_class;
    out << "\n";
  }
}

}  // namespace ssrfleet::io
