#include "io/wim_log.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "records/vehicle_class.hpp"
#include "util/errors.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::io {

namespace {
// Columns named prefix1..prefixM, consecutive from 1, in any order in the header.
std::vector<long> numbered_columns(const std::vector<std::string>& header, const std::string& prefix,
                                   std::vector<std::string>& names) {
  std::vector<long> cols = io::numbered_columns(header, prefix);
  for (std::size_t m = 1; m <= cols.size(); ++m) names.push_back(prefix + std::to_string(m));
  return cols;
}

std::string format_range(double lo, double hi) {
  std::ostringstream os;
  os << "[" << lo << ", " << hi << "]";
  return os.str();
}
}  // namespace

WimLogReader::WimLogReader(std::istream& in, std::string source_name, double unsprung_mass_kg,
                           WimLimits limits)
    : csv_(in, std::move(source_name)), unsprung_mass_kg_(unsprung_mass_kg), limits_(limits) {
  CsvRow header;
  if (!csv_.next(header)) throw DataError(csv_.source_name(), 1, "header", "empty file: no header line");
  header_raw_ = header.raw;
  header_line_ = header.line;
  header_fields_ = header.fields.size();
  const auto& h = header.fields;
  const auto require = [&](const char* name) {
    const long c = column_index(h, name);
    if (c < 0) throw DataError(csv_.source_name(), header.line, name, "required column is missing from the header");
    return c;
  };
  id_col_ = require("truck_id");
  speed_col_ = require("speed_mps");
  mass_col_ = require("sprung_mass_kg");
  time_col_ = column_index(h, "time_s");
  class_col_ = column_index(h, "class");
  site_col_ = column_index(h, "site");  // read only in a log of several sites (set_sites)
  std::vector<std::string> if_names, force_names;
  const auto if_cols = numbered_columns(h, "if_", if_names);
  const auto force_cols = numbered_columns(h, "force_", force_names);
  if (!if_cols.empty() && !force_cols.empty()) {
    throw DataError(csv_.source_name(), header.line, "if_1", "both if_ and force_ columns present; give one kind");
  }
  if (if_cols.empty() && force_cols.empty()) {
    throw DataError(csv_.source_name(), header.line, "if_1",
                    "required column is missing from the header (need if_1..if_M or force_1..force_M)");
  }
  forces_ = if_cols.empty();
  value_cols_ = forces_ ? force_cols : if_cols;
  value_names_ = forces_ ? force_names : if_names;
  sensors_ = static_cast<int>(value_cols_.size());
}

void WimLogReader::keep_ids_in(const std::string& directory) {
  if (seen_.size() > 0) throw std::logic_error("WimLogReader::keep_ids_in: ids were seen already");
  seen_ = util::SpillStringSet(directory);
}

void WimLogReader::set_sites(std::vector<LogSite> sites) {
  const std::string& src = csv_.source_name();
  if (site_col_ < 0) {
    throw DataError(src, header_line_, "site",
                    "required column is missing from the header (a log of several sites names each record's site)");
  }
  for (const auto& s : sites) {
    if (s.sensors > sensors_) {
      throw DataError(src, header_line_, std::string(forces_ ? "force_" : "if_") + std::to_string(sensors_ + 1),
                      "site '" + s.name + "' has " + std::to_string(s.sensors) + " sensors but the header has " +
                          std::to_string(sensors_) + " value columns");
    }
  }
  sites_ = std::move(sites);
}

records::WimRecord WimLogReader::parse(const CsvRow& row) const {
  const std::string& src = csv_.source_name();
  if (row.fields.size() != header_fields_) {
    throw DataError(src, row.line, "columns",
                    "row has " + std::to_string(row.fields.size()) + " fields but the header has " +
                        std::to_string(header_fields_));
  }
  records::WimRecord r;
  r.line = row.line;
  r.truck_id = row.fields[static_cast<std::size_t>(id_col_)];
  if (r.truck_id.empty()) throw DataError(src, row.line, "truck_id", "empty truck_id");
  int sensors = sensors_;
  if (!sites_.empty()) {
    const std::string& name = row.fields[static_cast<std::size_t>(site_col_)];
    const auto it = std::find_if(sites_.begin(), sites_.end(), [&](const LogSite& s) { return s.name == name; });
    if (it == sites_.end()) {
      std::string known;
      for (const auto& s : sites_) known += (known.empty() ? "" : ", ") + s.name;
      throw DataError(src, row.line, "site",
                      name.empty() ? "empty: the record names no site (the manifest's sites: " + known + ")"
                                   : "site '" + name + "' is not one of the manifest's sites (" + known + ")");
    }
    r.site = static_cast<std::uint32_t>(it - sites_.begin());
    sensors = it->sensors;
    r.truck_id = name + ":" + r.truck_id;  // ids are per site
  }
  if (seen_.contains(r.truck_id)) throw DataError(src, row.line, "truck_id", "duplicate truck_id '" + r.truck_id + "'");
  if (class_col_ >= 0) {
    const std::string& label = row.fields[static_cast<std::size_t>(class_col_)];
    if (!records::is_class_label(label)) {
      throw DataError(src, row.line, "class",
                      "class label '" + label + "' is not a label (one or more of A-Z a-z 0-9 _ . -)");
    }
    if (limits_.fhwa_classes && !records::is_fhwa_class(label)) {
      throw DataError(src, row.line, "class", "class label '" + label + "' is not an FHWA class (1 to 13)");
    }
    if (!classes_.empty() && !classes_.count(label)) {
      std::string known;
      for (const auto& c : classes_) known += (known.empty() ? "" : ", ") + c;
      throw DataError(src, row.line, "class", "class '" + label + "' is not one of the classes fixed for this input (" + known + ")");
    }
    r.vehicle_class = label;
  }
  if (time_col_ >= 0) r.time_s = parse_finite(row.fields[static_cast<std::size_t>(time_col_)], src, row.line, "time_s");
  r.speed_mps = parse_finite(row.fields[static_cast<std::size_t>(speed_col_)], src, row.line, "speed_mps");
  if (r.speed_mps < limits_.min_speed_mps || r.speed_mps > limits_.max_speed_mps) {
    throw DataError(src, row.line, "speed_mps",
                    "speed " + row.fields[static_cast<std::size_t>(speed_col_)] + " m/s is outside " +
                        format_range(limits_.min_speed_mps, limits_.max_speed_mps));
  }
  r.sprung_mass_kg = parse_finite(row.fields[static_cast<std::size_t>(mass_col_)], src, row.line, "sprung_mass_kg");
  if (r.sprung_mass_kg < limits_.min_sprung_mass_kg || r.sprung_mass_kg > limits_.max_sprung_mass_kg) {
    throw DataError(src, row.line, "sprung_mass_kg",
                    "sprung mass " + row.fields[static_cast<std::size_t>(mass_col_)] + " kg is outside " +
                        format_range(limits_.min_sprung_mass_kg, limits_.max_sprung_mass_kg));
  }
  const double static_weight_n = (unsprung_mass_kg_ + r.sprung_mass_kg) * vehicle::gravity_mps2;
  r.impact_factor.resize(sensors);
  for (int m = sensors; m < sensors_; ++m) {
    if (!row.fields[static_cast<std::size_t>(value_cols_[static_cast<std::size_t>(m)])].empty()) {
      throw DataError(src, row.line, value_names_[static_cast<std::size_t>(m)],
                      "site '" + sites_[r.site].name + "' has " + std::to_string(sensors) + " sensors: leave " +
                          value_names_[static_cast<std::size_t>(m)] + " empty");
    }
  }
  for (int m = 0; m < sensors; ++m) {
    const auto& name = value_names_[static_cast<std::size_t>(m)];
    const double v = parse_finite(row.fields[static_cast<std::size_t>(value_cols_[static_cast<std::size_t>(m)])], src,
                                  row.line, name);
    const double impact = forces_ ? v / static_weight_n : v;
    if (impact < limits_.min_impact_factor || impact > limits_.max_impact_factor) {
      throw DataError(src, row.line, name,
                      std::string("impact factor ") + std::to_string(impact) + " is impossible (outside " +
                          format_range(limits_.min_impact_factor, limits_.max_impact_factor) + ")");
    }
    r.impact_factor[m] = impact;
  }
  return r;
}

WimLogReader::Status WimLogReader::next(records::WimRecord& record, Rejection& why) {
  CsvRow row;
  if (!csv_.next(row)) return Status::end;
  try {
    record = parse(row);
    seen_.insert(record.truck_id);
    return Status::record;
  } catch (const DataError& e) {
    why.line = row.line;
    why.raw = row.raw;
    why.field = e.field();
    why.reason = e.reason();
    why.message = e.what();
    return Status::rejected;
  }
}

std::vector<records::WimRecord> read_wim_log_file(const std::string& path, double unsprung_mass_kg, int* sensors_out,
                                                  const WimLimits& limits, std::size_t* header_line_out) {
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open WIM log '" + path + "'");
  WimLogReader reader(in, path, unsprung_mass_kg, limits);
  std::vector<records::WimRecord> records;
  records::WimRecord r;
  Rejection why;
  for (;;) {
    const auto status = reader.next(r, why);
    if (status == WimLogReader::Status::end) break;
    if (status == WimLogReader::Status::rejected) throw DataError(path, why.line, why.field, why.reason);
    records.push_back(std::move(r));
  }
  if (in.bad()) throw IoError("reading '" + path + "' failed");
  if (records.empty()) throw DataError(path, reader.header_line_number() + 1, "truck_id", "the log holds no truck records");
  if (sensors_out) *sensors_out = reader.sensors();
  if (header_line_out) *header_line_out = reader.header_line_number();
  return records;
}

void write_wim_log(std::ostream& out, const std::vector<records::WimRecord>& records) {
  const Eigen::Index sensors = records.empty() ? 0 : records.front().impact_factor.size();
  const bool with_time = !records.empty() && records.front().time_s.has_value();
  const bool with_class =
      std::any_of(records.begin(), records.end(), [](const records::WimRecord& r) { return !r.vehicle_class.empty(); });
  out << "truck_id";
  if (with_time) out << ",time_s";
  if (with_class) out << ",class";
  out << ",speed_mps,sprung_mass_kg";
  for (Eigen::Index m = 1; m <= sensors; ++m) out << ",if_" << m;
  out << "\n";
  out.precision(std::numeric_limits<double>::max_digits10);
  for (const auto& r : records) {
    out << r.truck_id;
    if (with_time) out << "," << r.time_s.value_or(0.0);
    if (with_class) out << "," << r.vehicle_class;
    out << "," << r.speed_mps << "," << r.sprung_mass_kg;
    for (Eigen::Index m = 0; m < r.impact_factor.size(); ++m) out << "," << r.impact_factor[m];
    out << "\n";
  }
}

}  // namespace ssrfleet::io
