#include "serve/state_reader.hpp"

#include <sqlite3.h>
#include <sys/stat.h>

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "io/history_db.hpp"
#include "util/errors.hpp"

namespace ssrfleet::serve {

namespace {

// A prepared statement that finalises itself; errors are DataErrors naming the file.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const std::string& path) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) fail("prepare");
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(stmt_, i, v); }
  void bind(int i, double v) { sqlite3_bind_double(stmt_, i, v); }
  void bind(int i, const std::string& v) { sqlite3_bind_text(stmt_, i, v.c_str(), -1, SQLITE_TRANSIENT); }
  bool next() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail("read");
    return false;
  }
  std::int64_t integer(int c) const { return sqlite3_column_int64(stmt_, c); }
  double real(int c) const { return sqlite3_column_double(stmt_, c); }
  std::string text(int c) const {
    const auto* t = sqlite3_column_text(stmt_, c);
    return t ? reinterpret_cast<const char*>(t) : "";
  }
  bool null(int c) const { return sqlite3_column_type(stmt_, c) == SQLITE_NULL; }

 private:
  [[noreturn]] void fail(const char* what) {
    throw DataError(path_, 0, "history", std::string("cannot ") + what + ": " + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* stmt_ = nullptr;
};

// One read transaction: every statement inside sees the same committed state of the database.
class ReadTransaction {
 public:
  ReadTransaction(sqlite3* db, const std::string& path) : db_(db) {
    char* error = nullptr;
    if (sqlite3_exec(db, "BEGIN;", nullptr, nullptr, &error) != SQLITE_OK) {
      const std::string why = error ? error : "?";
      sqlite3_free(error);
      throw DataError(path, 0, "history", "cannot begin a read: " + why);
    }
  }
  ~ReadTransaction() { sqlite3_exec(db_, "COMMIT;", nullptr, nullptr, nullptr); }
  ReadTransaction(const ReadTransaction&) = delete;
  ReadTransaction& operator=(const ReadTransaction&) = delete;

 private:
  sqlite3* db_;
};

std::string hex(std::uint64_t v) {
  char buffer[17];
  std::snprintf(buffer, sizeof buffer, "%016" PRIx64, v);
  return buffer;
}

}  // namespace

StateReader::StateReader(std::string history_path) : path_(std::move(history_path)) {}

StateReader::~StateReader() {
  if (db_ != nullptr) sqlite3_close_v2(db_);
}

bool StateReader::open() {
  const std::lock_guard<std::mutex> lock(mutex_);
  return open_locked();
}

bool StateReader::open_locked() {
  if (db_ != nullptr) return true;
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) return false;  // no history yet: the stream has not started
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path_.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr) != SQLITE_OK) {
    const std::string why = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close_v2(db);
    throw IoError("cannot open '" + path_ + "' read-only: " + why);
  }
  // The writer holds its locks for the few milliseconds of a commit.
  sqlite3_busy_timeout(db, 2000);
  db_ = db;
  return true;
}

std::optional<std::uint64_t> StateReader::last_seq() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!open_locked()) return std::nullopt;
  // A database the stream has just created may not have its tables yet.
  Statement has(db_, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'reports';", path_);
  if (!has.next() || has.integer(0) == 0) return std::nullopt;
  Statement s(db_, "SELECT max(seq) FROM reports;", path_);
  if (!s.next() || s.null(0)) return std::nullopt;
  return static_cast<std::uint64_t>(s.integer(0));
}

std::optional<Snapshot> StateReader::snapshot() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!open_locked()) return std::nullopt;
  const ReadTransaction transaction(db_, path_);
  {
    Statement has(db_, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'reports';",
                  path_);
    if (!has.next() || has.integer(0) == 0) return std::nullopt;
  }
  Snapshot snap;
  records::HistoryReport& r = snap.report;
  std::string stored_checksum;
  {
    Statement s(db_,
                "SELECT seq, trucks, time_s, source, lines_consumed, ess, checkpoint_checksum, row_checksum "
                "FROM reports ORDER BY seq DESC LIMIT 1;",
                path_);
    if (!s.next()) return std::nullopt;
    r.seq = static_cast<std::uint64_t>(s.integer(0));
    r.trucks = s.integer(1);
    r.time_s = s.real(2);
    r.source = s.text(3);
    r.lines_consumed = static_cast<std::uint64_t>(s.integer(4));
    r.ess = s.real(5);
    r.checkpoint_checksum = std::strtoull(s.text(6).c_str(), nullptr, 16);
    stored_checksum = s.text(7);
  }
  {
    // rowid order is the order written, the one the checksum covers.
    Statement s(db_,
                "SELECT class, name, mean, sd, q025, q975 FROM hyperparameters WHERE seq = ? ORDER BY rowid;",
                path_);
    s.bind(1, static_cast<std::int64_t>(r.seq));
    while (s.next()) {
      r.hyperparameters.push_back({s.text(0), s.text(1), s.real(2), s.real(3), s.real(4), s.real(5)});
      if (snap.classes.empty() || snap.classes.back() != r.hyperparameters.back().vehicle_class) {
        snap.classes.push_back(r.hyperparameters.back().vehicle_class);
      }
    }
  }
  {
    Statement s(db_,
                "SELECT position_m, mean_if, lower95, upper95, mean_lower95, mean_upper95 FROM predictions "
                "WHERE seq = ? ORDER BY rowid;",
                path_);
    s.bind(1, static_cast<std::int64_t>(r.seq));
    while (s.next())
      r.predictions.push_back({s.real(0), s.real(1), s.real(2), s.real(3), s.real(4), s.real(5)});
  }
  if (hex(io::history_row_checksum(r)) != stored_checksum) {
    throw DataError(path_, 0, "row_checksum",
                    "report " + std::to_string(r.seq) +
                        " does not match its checksum: the history was changed or "
                        "damaged after it was written");
  }
  {
    Statement s(db_, "SELECT value FROM meta WHERE key = 'model';", path_);
    snap.model = s.next() ? s.text(0) : "base";
  }
  {
    Statement s(db_, "SELECT trucks, time_s FROM reports WHERE time_s >= ? ORDER BY seq ASC LIMIT 1;", path_);
    s.bind(1, r.time_s - 60.0);
    snap.window_trucks = r.trucks;
    snap.window_time_s = r.time_s;
    if (s.next()) {
      snap.window_trucks = s.integer(0);
      snap.window_time_s = s.real(1);
    }
  }
  return snap;
}

std::vector<HistorySeries> StateReader::history(const HistoryQuery& q) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<HistorySeries> out;
  if (!open_locked()) return out;
  const ReadTransaction transaction(db_, path_);
  // The range in trucks, bounded by the checkpoint.
  std::int64_t last_trucks = 0;
  {
    Statement s(db_, "SELECT trucks FROM reports WHERE seq = ?;", path_);
    s.bind(1, static_cast<std::int64_t>(q.max_seq));
    if (!s.next()) return out;
    last_trucks = s.integer(0);
  }
  // The class's first report: a state resumed from an older one may start past 1, and a vehicle
  // class starts at its first truck.
  std::int64_t first_trucks = 1;
  {
    Statement s(db_,
                "SELECT r.trucks FROM hyperparameters h JOIN reports r ON r.seq = h.seq WHERE h.class = ? "
                "ORDER BY h.seq ASC LIMIT 1;",
                path_);
    s.bind(1, q.vehicle_class);
    if (!s.next()) return out;
    first_trucks = s.integer(0);
  }
  const std::int64_t from = std::max<std::int64_t>(first_trucks, q.from_trucks);
  const std::int64_t to = q.to_trucks > 0 ? std::min(q.to_trucks, last_trucks) : last_trucks;
  if (to < from) return out;
  const std::int64_t span = to - from + 1;
  // Every step-th report from `from` takes at most points - 1 places, the range's last one more.
  const std::int64_t places = std::max(1, q.points - 2);
  const std::int64_t step = q.points <= 2 ? std::max<std::int64_t>(1, span)
                                          : std::max<std::int64_t>(1, (span - 1 + places - 1) / places);
  // Every step-th report from `from`, and the range's last (the newest point is always drawn).
  Statement s(db_,
              "SELECT r.trucks, h.name, h.mean, h.q025, h.q975 FROM reports r JOIN hyperparameters h ON "
              "h.seq = r.seq "
              "WHERE r.seq <= ?1 AND h.class = ?2 AND r.trucks BETWEEN ?3 AND ?4 "
              "AND ((r.trucks - ?3) % ?5 = 0 OR r.trucks = ?4) AND (?6 = '' OR h.name = ?6) "
              "ORDER BY r.seq, h.rowid;",
              path_);
  s.bind(1, static_cast<std::int64_t>(q.max_seq));
  s.bind(2, q.vehicle_class);
  s.bind(3, from);
  s.bind(4, to);
  s.bind(5, step);
  s.bind(6, q.name.value_or(""));
  while (s.next()) {
    const std::string name = s.text(1);
    HistorySeries* series = nullptr;
    for (auto& have : out) {
      if (have.name == name) series = &have;
    }
    if (series == nullptr) {
      out.push_back({name, {}, {}, {}, {}});
      series = &out.back();
    }
    series->trucks.push_back(s.integer(0));
    series->mean.push_back(s.real(2));
    series->q025.push_back(s.real(3));
    series->q975.push_back(s.real(4));
  }
  return out;
}

std::optional<std::uint64_t> StateReader::seq_of_trucks(std::int64_t trucks) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!open_locked()) return std::nullopt;
  Statement s(db_, "SELECT seq FROM reports WHERE trucks = ? ORDER BY seq DESC LIMIT 1;", path_);
  s.bind(1, trucks);
  if (!s.next()) return std::nullopt;
  return static_cast<std::uint64_t>(s.integer(0));
}

}  // namespace ssrfleet::serve
