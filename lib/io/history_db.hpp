// The stream state's history: every checkpoint's report in an SQLite database (history.sqlite in
// the state directory), so users can ask how the posterior and the SSR prediction evolved
// (docs/outputs.md documents the schema and a query). A format: it stores and reads
// records::HistoryReport and computes nothing.
//
// Schema (version 1):
//   meta(key TEXT PRIMARY KEY, value TEXT)         schema_version, model
//   reports(seq INTEGER PRIMARY KEY, trucks, time_s, source, lines_consumed, ess,
//           checkpoint_checksum TEXT, row_checksum TEXT)
//   hyperparameters(seq, class, name, mean, sd, q025, q975)          PRIMARY KEY (seq, class, name)
//   predictions(seq, position_m, mean_if, lower95, upper95, mean_lower95, mean_upper95)
//                                                                          PRIMARY KEY (seq, position_m)
// A checkpoint's rows are written in one transaction; the database runs in WAL mode, so readers
// (predict, the sqlite3 shell, a dashboard) read while the stream writes, and with synchronous=FULL,
// so a committed row set survives a power cut as the checkpoint file does.
// SQLite does not checksum its pages: each report carries row_checksum, an FNV-1a hash of its own
// values and of its rows in the two other tables, which read_report() verifies.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "records/history_report.hpp"

struct sqlite3;

namespace ssrfleet::io {

class HistoryDb {
 public:
  // Opens the database at `path`, creating it and its schema if missing; `model` is recorded on
  // creation and must match on later opens. IoError if it cannot be opened or written (a read-only
  // directory); DataError naming the path if it is not a history database or is damaged.
  HistoryDb(const std::string& path, const std::string& model);
  ~HistoryDb();
  HistoryDb(const HistoryDb&) = delete;
  HistoryDb& operator=(const HistoryDb&) = delete;

  // Writes one report's rows in one transaction (all or nothing); a full disk is an IoError and
  // leaves the database as it was.
  void append(const records::HistoryReport& report);
  // The highest seq stored, none for an empty history.
  std::optional<std::uint64_t> last_seq() const;
  // The report number `seq` with its rows, after checking its row_checksum (DataError naming the
  // path and the seq if it does not match or the report is missing).
  records::HistoryReport read_report(std::uint64_t seq) const;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

// The FNV-1a hash that row_checksum holds (everything in the report but row_checksum itself).
std::uint64_t history_row_checksum(const records::HistoryReport& report);

}  // namespace ssrfleet::io
