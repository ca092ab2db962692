// The WIM-log CSV of docs/site-data.md: header first, '#' lines are comments. Columns `truck_id`
// (unique), `time_s` (optional), `class` (optional: the truck's vehicle class, a label of
// [A-Za-z0-9_.-]+, records/vehicle_class.hpp), `site` (a log of several sites: set_sites),
// `speed_mps`, `sprung_mass_kg`, then either
// `if_1`..`if_M` (impact factors) or `force_1`..`force_M` (tyre force, N). Extra columns are ignored.
//
// The reader is incremental and never stops on a bad record: it hands the record back as a
// Rejection (line, verbatim text, field, reason), so a stream can quarantine it and go on, and
// an offline replay can turn the first one into an error.
#pragma once

#include <cstddef>
#include <istream>
#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "io/csv_reader.hpp"
#include "records/wim_record.hpp"
#include "util/spill_strings.hpp"

namespace ssrfleet::io {

struct Rejection {
  std::size_t line = 0;
  std::string raw;      // the record verbatim, for a rejects file
  std::string field;
  std::string reason;
  std::string message;  // "file:line: field 'x': reason"
};

// What a record may hold and still be physical. A tyre force sensor reads >= 0 (a wheel in the
// air reads 0), and four times the static load is far beyond any truck on a road that is still
// open, so an IF outside [0, 4] is a fault, not a truck.
struct WimLimits {
  double min_speed_mps = 0.5;
  double max_speed_mps = 60.0;
  double min_sprung_mass_kg = 100.0;
  double max_sprung_mass_kg = 60000.0;
  double min_impact_factor = 0.0;
  double max_impact_factor = 4.0;
  // The `class` column must hold FHWA's classes "1".."13" (otherwise any label).
  bool fhwa_classes = false;
};

class WimLogReader {
 public:
  enum class Status { record, rejected, end };

  // Reads and checks the header; throws DataError (line 1 or the header's line, field = the
  // missing column) if a required column is missing, or if both if_ and force_ columns are
  // present. unsprung_mass_kg converts tyre forces to impact factors: IF = F / ((m1 + m2) g).
  WimLogReader(std::istream& in, std::string source_name, double unsprung_mass_kg,
               WimLimits limits = {});

  int sensors() const { return sensors_; }
  bool reads_forces() const { return forces_; }
  bool has_classes() const { return class_col_ >= 0; }  // the header has a `class` column
  const std::string& source_name() const { return csv_.source_name(); }
  const std::string& header_line() const { return header_raw_; }
  // The header's line number in the file (comment lines above it count): where a complaint about
  // the columns points.
  std::size_t header_line_number() const { return header_line_; }

  // Next record: `record` on success, `rejected` (with `why` filled) for a bad one, `end` at EOF.
  Status next(records::WimRecord& record, Rejection& why);

  // Truck ids the reader treats as already absorbed (e.g. after a resume): a later record with
  // one of these ids is rejected as a duplicate.
  void mark_seen(const std::string& truck_id) { seen_.insert(truck_id); }
  // Keeps the ids seen in spill files in `directory` ("": in memory, the default), so a long
  // stream's memory does not grow with them (util/spill_strings.hpp). Before the first record
  // (std::logic_error after one); IoError if no file can be made there.
  void keep_ids_in(const std::string& directory);
  void set_follow(bool follow) { csv_.set_follow(follow); }
  // The only classes accepted (empty = any label): a record of another class is rejected, field
  // `class` (a stream whose classes were fixed when its state was made).
  void set_classes(std::set<std::string> classes) { classes_ = std::move(classes); }

  // A log of several sites (a stream of a site manifest, docs/sites.md): the header must have a
  // `site` column, and at least as many value columns as the site with the most sensors. A record's
  // site names one of `sites` (WimRecord::site is its index); it fills its site's first M_s value
  // columns and leaves the rest empty; its truck id is kept as "SITE:ID", since ids are per site
  // (the same id at two sites is two trucks). A record of no or an unknown site is rejected, field
  // `site`. DataError (the header's line, field `site` or the first missing value column) if the
  // header cannot carry these sites.
  struct LogSite {
    std::string name;
    int sensors = 0;
  };
  void set_sites(std::vector<LogSite> sites);

 private:
  records::WimRecord parse(const CsvRow& row) const;

  CsvReader csv_;
  double unsprung_mass_kg_;
  WimLimits limits_;
  std::string header_raw_;
  std::size_t header_line_ = 1;
  std::size_t header_fields_ = 0;
  long id_col_ = -1, time_col_ = -1, class_col_ = -1, speed_col_ = -1, mass_col_ = -1;
  std::vector<long> value_cols_;
  std::vector<std::string> value_names_;
  int sensors_ = 0;
  bool forces_ = false;
  util::SpillStringSet seen_;
  std::set<std::string> classes_;
  long site_col_ = -1;
  std::vector<LogSite> sites_;  // empty: a log of one site
};

// Reads a whole log; the first bad record is an error (DataError naming file, line, field).
// header_line_out: the header's line number, for the caller's own complaints about the columns.
std::vector<records::WimRecord> read_wim_log_file(const std::string& path, double unsprung_mass_kg,
                                                  int* sensors_out = nullptr, const WimLimits& limits = {},
                                                  std::size_t* header_line_out = nullptr);

// Writes records as a WIM log with if_ columns, full precision (round trips bit-exactly); with a
// `class` column when any record has a class.
void write_wim_log(std::ostream& out, const std::vector<records::WimRecord>& records);

}  // namespace ssrfleet::io
