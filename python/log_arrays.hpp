// A WIM log given as arrays from Python: the tuple the package's _log_arrays makes (truck_id,
// time_s or None, speed_mps, sprung_mass_kg, impact_factor (trucks x sensors), class or None) as
// records, and records as the WIM log's CSV text. fit reads that text back through the log reader
// (every check a log file gets); a stream reads it as its input, quarantining the rows it rejects.
#pragma once

#include <string>
#include <vector>

#include <pybind11/pybind11.h>

#include "io/wim_log.hpp"
#include "records/wim_record.hpp"
#include "site_handle.hpp"

namespace ssrfleet::python {

// The rows as records, in order, with their values as given (NaN included: the reader judges
// them). UsageError when the arrays' lengths disagree; DataError (file "log", line 1) when the
// impact factors' columns are not the site's sensors.
std::vector<records::WimRecord> records_of_tuple(const pybind11::tuple& arrays, const SiteHandle& where);

// The WIM log CSV of the records (io::write_wim_log: every number to its bits).
std::string log_text(const std::vector<records::WimRecord>& records);

// The rows read back through the log reader with `limits`, as fit takes a log: the first rejected
// row is a DataError naming the file "log", its line (the header is line 1, row r is line r + 2)
// and its field.
std::vector<records::WimRecord> read_log_arrays(const pybind11::tuple& arrays, const SiteHandle& where,
                                                const io::WimLimits& limits);

}  // namespace ssrfleet::python
