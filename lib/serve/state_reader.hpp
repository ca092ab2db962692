// What `serve` reads of a stream's history (history.sqlite, docs/outputs.md): the latest
// checkpoint's report and, on request, a parameter's history. Read-only in the strongest sense
// SQLite offers: the connection is opened with SQLITE_OPEN_READONLY (a missing database is not
// created, and no statement can write), and every read of several tables runs in one read
// transaction, so a report and its rows always belong to the same checkpoint however fast the
// stream commits (WAL mode: a reader sees the database as of its transaction's first read).
// SQLite itself keeps the database's -wal and -shm files beside it while any connection is open;
// nothing else in the state directory is opened here.
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "records/history_report.hpp"

struct sqlite3;

namespace ssrfleet::serve {

struct Snapshot {
  records::HistoryReport report;     // the latest checkpoint's report, its row checksum verified
  std::string model;                 // the state's model spec (meta.model)
  std::vector<std::string> classes;  // the vehicle classes of that report ("" alone: no classes)
  // The oldest report written at most 60 s before this one: trucks per minute at time t are
  // (report.trucks - window_trucks) / (t - window_time_s) * 60, which falls as a stream stalls.
  std::int64_t window_trucks = 0;
  double window_time_s = 0.0;
};

// One hyperparameter's posterior summary against trucks absorbed.
struct HistorySeries {
  std::string name;
  std::vector<std::int64_t> trucks;
  std::vector<double> mean, q025, q975;
};

struct HistoryQuery {
  std::uint64_t max_seq = 0;                    // the snapshot's checkpoint: nothing later is read
  std::string vehicle_class;                    // "" for a state without classes
  std::optional<std::string> name;              // one hyperparameter, or all of them
  std::int64_t from_trucks = 1, to_trucks = 0;  // inclusive; to 0 = up to the checkpoint
  int points = 400;  // at most this many reports, evenly spaced in trucks, the last always included
};

class StateReader {
 public:
  explicit StateReader(std::string history_path);
  ~StateReader();
  StateReader(const StateReader&) = delete;
  StateReader& operator=(const StateReader&) = delete;

  // The highest seq, none while the database or its first report does not exist yet. Cheap: the
  // poll that notices a new checkpoint.
  std::optional<std::uint64_t> last_seq();
  // The latest checkpoint whole (one read transaction); none as above. DataError naming the file
  // and row_checksum when the report's rows do not match their checksum.
  std::optional<Snapshot> snapshot();
  // The series of every hyperparameter (or the one named) over reports up to q.max_seq.
  std::vector<HistorySeries> history(const HistoryQuery& q);
  // The checkpoint whose report counts `trucks` trucks (a posterior file's trucks_seen): trucks
  // rise by one per checkpoint, so this names the checkpoint a posterior.json belongs to.
  std::optional<std::uint64_t> seq_of_trucks(std::int64_t trucks);
  // Whether the database has been seen at all (false until history.sqlite exists).
  bool open();

  const std::string& path() const { return path_; }

 private:
  bool open_locked();
  std::string path_;
  sqlite3* db_ = nullptr;
  std::mutex mutex_;  // one statement sequence at a time on the connection
};

}  // namespace ssrfleet::serve
