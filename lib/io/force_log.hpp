// The tyre-force WIM log that `ssrfleet weigh` reads: the force_1..force_M form
// of the WIM log of docs/site-data.md (header first, '#' lines are comments; `truck_id`, `time_s`
// optional, `speed_mps`, then `force_1`..`force_M` in N), except that `sprung_mass_kg` may be
// absent: the static weight is what weigh estimates. Extra columns are ignored.
//
// Every bad value is a DataError naming file, line and field: a missing column (at the header's
// line), a non-numeric or non-finite value, a negative force (a tyre sensor reads >= 0; a wheel in
// the air reads 0), a speed outside WimLimits, a duplicate truck id, a row of the wrong length,
// and a sensor count other than the site's.
#pragma once

#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "io/wim_log.hpp"
#include "records/force_record.hpp"

namespace ssrfleet::io {

// Reads a whole force log. expected_sensors > 0: the log must have exactly that many force columns
// (the site's sensors), else DataError at the header's line naming the first missing or the first
// extra force column; site_note ends that message (e.g. "(--sensors 76,1.5,16)").
std::vector<records::ForceRecord> read_force_log(std::istream& in, const std::string& source_name, int expected_sensors,
                                                 const std::string& site_note = "", WimLimits limits = {});
// The same from a file; MissingInputError if it cannot be opened.
std::vector<records::ForceRecord> read_force_log_file(const std::string& path, int expected_sensors,
                                                      const std::string& site_note = "", WimLimits limits = {});

// Writes a force log: truck_id, speed_mps, sprung_mass_kg (only when with_sprung_mass and every
// record has one), force_1..force_M, full precision.
void write_force_log(std::ostream& out, const std::vector<records::ForceRecord>& records, bool with_sprung_mass);

}  // namespace ssrfleet::io
