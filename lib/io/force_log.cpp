#include "io/force_log.hpp"

#include <algorithm>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_set>

#include "io/csv_reader.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
std::string format_range(double lo, double hi) {
  std::ostringstream os;
  os << "[" << lo << ", " << hi << "]";
  return os.str();
}
}  // namespace

std::vector<records::ForceRecord> read_force_log(std::istream& in, const std::string& src, int expected_sensors,
                                                 const std::string& site_note, WimLimits limits) {
  CsvReader csv(in, src);
  CsvRow header;
  if (!csv.next(header)) throw DataError(src, 1, "header", "empty file: no header line");
  const auto& h = header.fields;
  const auto require = [&](const char* name) {
    const long c = column_index(h, name);
    if (c < 0) throw DataError(src, header.line, name, "required column is missing from the header");
    return static_cast<std::size_t>(c);
  };
  const std::size_t id_col = require("truck_id");
  const std::size_t speed_col = require("speed_mps");
  const long time_col = column_index(h, "time_s"), mass_col = column_index(h, "sprung_mass_kg");
  std::vector<std::size_t> force_cols;
  for (const long c : numbered_columns(h, "force_")) force_cols.push_back(static_cast<std::size_t>(c));
  if (force_cols.empty()) {
    const bool impact_factors = column_index(h, "if_1") >= 0;
    throw DataError(src, header.line, "force_1",
                    impact_factors ? "the log holds impact factors (if_1..); weigh needs the raw tyre forces force_1..force_M "
                                     "in N (an impact factor is already divided by the static weight weigh estimates)"
                                   : "required column is missing from the header (need force_1..force_M, N)");
  }
  const int sensors = static_cast<int>(force_cols.size());
  if (expected_sensors > 0 && sensors != expected_sensors) {
    const int first_wrong = std::min(sensors, expected_sensors) + 1;
    throw DataError(src, header.line, "force_" + std::to_string(first_wrong),
                    "the log has " + std::to_string(sensors) + " force columns but the posterior's site has " +
                        std::to_string(expected_sensors) + " sensors" + (site_note.empty() ? "" : " " + site_note));
  }

  std::vector<records::ForceRecord> records;
  std::unordered_set<std::string> seen;
  CsvRow row;
  while (csv.next(row)) {
    if (row.fields.size() != h.size()) {
      throw DataError(src, row.line, "columns",
                      "row has " + std::to_string(row.fields.size()) + " fields but the header has " + std::to_string(h.size()));
    }
    records::ForceRecord r;
    r.line = row.line;
    r.truck_id = row.fields[id_col];
    if (r.truck_id.empty()) throw DataError(src, row.line, "truck_id", "empty truck_id");
    if (!seen.insert(r.truck_id).second) throw DataError(src, row.line, "truck_id", "duplicate truck_id '" + r.truck_id + "'");
    if (time_col >= 0) r.time_s = parse_finite(row.fields[static_cast<std::size_t>(time_col)], src, row.line, "time_s");
    r.speed_mps = parse_finite(row.fields[speed_col], src, row.line, "speed_mps");
    if (r.speed_mps < limits.min_speed_mps || r.speed_mps > limits.max_speed_mps) {
      throw DataError(src, row.line, "speed_mps",
                      "speed " + row.fields[speed_col] + " m/s is outside " + format_range(limits.min_speed_mps, limits.max_speed_mps));
    }
    // A sprung mass in the log is read and checked (a bad one is still bad data) but not used.
    if (mass_col >= 0 && !row.fields[static_cast<std::size_t>(mass_col)].empty()) {
      r.sprung_mass_kg = parse_finite(row.fields[static_cast<std::size_t>(mass_col)], src, row.line, "sprung_mass_kg");
    }
    r.force_n.resize(sensors);
    for (int m = 0; m < sensors; ++m) {
      const std::string field = "force_" + std::to_string(m + 1);
      const std::string& text = row.fields[force_cols[static_cast<std::size_t>(m)]];
      const double f = parse_finite(text, src, row.line, field);
      if (f < 0.0) {
        throw DataError(src, row.line, field, "force " + text + " N is negative: a tyre sensor reads >= 0 (a wheel in the air reads 0)");
      }
      r.force_n[m] = f;
    }
    if (!(r.force_n.sum() > 0.0)) throw DataError(src, row.line, "force_1", "every force is 0: no wheel crossed the sensors");
    records.push_back(std::move(r));
  }
  if (in.bad()) throw IoError("reading '" + src + "' failed");
  if (records.empty()) throw DataError(src, header.line + 1, "truck_id", "the log holds no truck records");
  return records;
}

std::vector<records::ForceRecord> read_force_log_file(const std::string& path, int expected_sensors,
                                                      const std::string& site_note, WimLimits limits) {
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open force log '" + path + "'");
  return read_force_log(in, path, expected_sensors, site_note, limits);
}

void write_force_log(std::ostream& out, const std::vector<records::ForceRecord>& records, bool with_sprung_mass) {
  const Eigen::Index sensors = records.empty() ? 0 : records.front().force_n.size();
  bool mass = with_sprung_mass;
  for (const auto& r : records) mass = mass && r.sprung_mass_kg.has_value();
  out << "truck_id,speed_mps";
  if (mass) out << ",sprung_mass_kg";
  for (Eigen::Index m = 1; m <= sensors; ++m) out << ",force_" << m;
  out << "\n";
  out.precision(std::numeric_limits<double>::max_digits10);
  for (const auto& r : records) {
    out << r.truck_id << "," << r.speed_mps;
    if (mass) out << "," << *r.sprung_mass_kg;
    for (Eigen::Index m = 0; m < r.force_n.size(); ++m) out << "," << r.force_n[m];
    out << "\n";
  }
}

}  // namespace ssrfleet::io
