#include "io/history_db.hpp"

#include <sqlite3.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "io/write_faults.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {

constexpr int kSchemaVersion = 1;

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS reports(
  seq INTEGER PRIMARY KEY, trucks INTEGER NOT NULL, time_s REAL NOT NULL, source TEXT NOT NULL,
  lines_consumed INTEGER NOT NULL, ess REAL NOT NULL, checkpoint_checksum TEXT NOT NULL,
  row_checksum TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS hyperparameters(
  seq INTEGER NOT NULL, class TEXT NOT NULL, name TEXT NOT NULL, mean REAL NOT NULL, sd REAL NOT NULL,
  q025 REAL NOT NULL, q975 REAL NOT NULL, PRIMARY KEY (seq, class, name));
CREATE TABLE IF NOT EXISTS predictions(
  seq INTEGER NOT NULL, position_m REAL NOT NULL, mean_if REAL NOT NULL, lower95 REAL NOT NULL,
  upper95 REAL NOT NULL, mean_lower95 REAL NOT NULL, mean_upper95 REAL NOT NULL,
  PRIMARY KEY (seq, position_m));
)sql";

std::string hex(std::uint64_t v) {
  char buffer[17];
  std::snprintf(buffer, sizeof buffer, "%016" PRIx64, v);
  return buffer;
}

// SQLite's codes for a damaged or foreign file are the user's data problem, not an I/O failure.
bool is_damage(int rc) {
  const int primary = rc & 0xff;
  return primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB || primary == SQLITE_FORMAT;
}

// One prepared statement, finalised on every path out.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const std::string& path) : db_(db), path_(path) {
    check(sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr), "prepare");
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void bind(int i, double v) { check(sqlite3_bind_double(stmt_, i, v), "bind"); }
  void bind(int i, std::int64_t v) { check(sqlite3_bind_int64(stmt_, i, v), "bind"); }
  void bind(int i, const std::string& v) {
    check(sqlite3_bind_text(stmt_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT), "bind");
  }
  // Runs to completion (a statement without rows).
  void run() {
    const int rc = sqlite3_step(stmt_);
    if (rc != SQLITE_DONE) check(rc, "write");
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  // Steps to the next row: false at the end.
  bool next() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc != SQLITE_DONE) check(rc, "read");
    return false;
  }
  double real(int c) const { return sqlite3_column_double(stmt_, c); }
  std::int64_t integer(int c) const { return sqlite3_column_int64(stmt_, c); }
  std::string text(int c) const {
    const auto* p = sqlite3_column_text(stmt_, c);
    return p ? reinterpret_cast<const char*>(p) : "";
  }
  bool null(int c) const { return sqlite3_column_type(stmt_, c) == SQLITE_NULL; }

  void check(int rc, const char* what) const {
    if (rc == SQLITE_OK) return;
    const std::string message = sqlite3_errmsg(db_);
    if (is_damage(rc)) throw DataError(path_, 0, what, "the history database is damaged: " + message);
    throw IoError("history database '" + path_ + "': " + what + " failed: " + message);
  }

 private:
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* stmt_ = nullptr;
};

void execute(sqlite3* db, const char* sql, const std::string& path, const char* what) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &error);
  if (rc == SQLITE_OK) return;
  const std::string message = error ? error : sqlite3_errstr(rc);
  sqlite3_free(error);
  if (is_damage(rc)) throw DataError(path, 0, what, "the history database is damaged: " + message);
  throw IoError("history database '" + path + "': " + what + " failed: " + message);
}

}  // namespace

std::uint64_t history_row_checksum(const records::HistoryReport& r) {
  std::uint64_t h = detail::kFnvOffset;
  auto add = [&h](const auto& v) { h = detail::fnv1a(h, reinterpret_cast<const char*>(&v), sizeof v); };
  auto add_text = [&h, &add](const std::string& s) {
    add(s.size());
    h = detail::fnv1a(h, s.data(), s.size());
  };
  add(r.seq);
  add(r.trucks);
  add(r.time_s);
  add_text(r.source);
  add(r.lines_consumed);
  add(r.ess);
  add(r.checkpoint_checksum);
  for (const auto& p : r.hyperparameters) {
    add_text(p.vehicle_class);
    add_text(p.name);
    for (double v : {p.mean, p.sd, p.q025, p.q975}) add(v);
  }
  for (const auto& p : r.predictions) {
    for (double v : {p.position_m, p.mean_if, p.lower95, p.upper95, p.mean_lower95, p.mean_upper95}) add(v);
  }
  return h;
}

namespace {

sqlite3* open_database(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    throw IoError("cannot open the history database '" + path + "': " + message);
  }
  sqlite3_busy_timeout(db, 10000);  // a reader's brief lock makes the writer wait, not fail
  return db;
}

// A new history is built under a temporary name and renamed into place, so a reader that finds
// the file always finds its tables.
void create_database(const std::string& path, const std::string& model) {
  const std::string tmp = path + ".new";
  std::remove(tmp.c_str());
  sqlite3* db = open_database(tmp);
  try {
    execute(db, "BEGIN;", tmp, "schema");
    execute(db, kSchema, tmp, "schema");
    Statement put(db, "INSERT INTO meta(key, value) VALUES (?, ?);", tmp);
    put.bind(1, std::string("schema_version"));
    put.bind(2, std::to_string(kSchemaVersion));
    put.run();
    put.bind(1, std::string("model"));
    put.bind(2, model);
    put.run();
  } catch (...) {
    sqlite3_close(db);
    std::remove(tmp.c_str());
    throw;
  }
  // Statement `put` is finalised above, so the commit and close leave no journal behind.
  const bool committed = sqlite3_exec(db, "COMMIT;", nullptr, nullptr, nullptr) == SQLITE_OK;
  const std::string message = sqlite3_errmsg(db);
  sqlite3_close(db);
  if (!committed || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw IoError("cannot create the history database '" + path + "': " + (committed ? std::strerror(errno) : message));
  }
}

}  // namespace

HistoryDb::HistoryDb(const std::string& path, const std::string& model) : path_(path) {
  if (FILE* existing = std::fopen(path.c_str(), "rb")) {
    std::fclose(existing);
  } else {
    create_database(path, model);
  }
  db_ = open_database(path);
  try {
    // WAL: readers never block the writer nor see half a transaction.
    execute(db_, "PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL;", path_, "journal_mode");
    {
      Statement tables(db_, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'meta';", path_);
      if (!tables.next() || tables.integer(0) == 0) {
        throw DataError(path_, 0, "meta", "not an ssrfleet history (no tables: an empty or cut file?)");
      }
    }
    {
      Statement version(db_, "SELECT value FROM meta WHERE key = 'schema_version';", path_);
      if (!version.next()) throw DataError(path_, 0, "schema_version", "not an ssrfleet history (no schema version)");
      if (version.text(0) != std::to_string(kSchemaVersion)) {
        throw DataError(path_, 0, "schema_version",
                        "history schema version " + version.text(0) + ", this build reads " +
                            std::to_string(kSchemaVersion));
      }
    }
    {
      Statement stored(db_, "SELECT value FROM meta WHERE key = 'model';", path_);
      if (stored.next() && stored.text(0) != model) {
        throw DataError(path_, 0, "model",
                        "the history was written with --model " + stored.text(0) + ", this stream fits " + model);
      }
    }
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

HistoryDb::~HistoryDb() { sqlite3_close(db_); }

void HistoryDb::append(const records::HistoryReport& r) {
  execute(db_, "BEGIN IMMEDIATE;", path_, "begin");
  try {
    Statement report(db_,
                     "INSERT INTO reports(seq, trucks, time_s, source, lines_consumed, ess, checkpoint_checksum, "
                     "row_checksum) VALUES (?, ?, ?, ?, ?, ?, ?, ?);",
                     path_);
    report.bind(1, static_cast<std::int64_t>(r.seq));
    report.bind(2, r.trucks);
    report.bind(3, r.time_s);
    report.bind(4, r.source);
    report.bind(5, static_cast<std::int64_t>(r.lines_consumed));
    report.bind(6, r.ess);
    report.bind(7, hex(r.checkpoint_checksum));
    report.bind(8, hex(history_row_checksum(r)));
    report.run();
    Statement hyper(db_,
                    "INSERT INTO hyperparameters(seq, class, name, mean, sd, q025, q975) VALUES (?, ?, ?, ?, ?, ?, ?);",
                    path_);
    for (const auto& p : r.hyperparameters) {
      hyper.bind(1, static_cast<std::int64_t>(r.seq));
      hyper.bind(2, p.vehicle_class);
      hyper.bind(3, p.name);
      hyper.bind(4, p.mean);
      hyper.bind(5, p.sd);
      hyper.bind(6, p.q025);
      hyper.bind(7, p.q975);
      hyper.run();
    }
    Statement prediction(db_,
                         "INSERT INTO predictions(seq, position_m, mean_if, lower95, upper95, mean_lower95, "
                         "mean_upper95) VALUES (?, ?, ?, ?, ?, ?, ?);",
                         path_);
    for (const auto& p : r.predictions) {
      prediction.bind(1, static_cast<std::int64_t>(r.seq));
      prediction.bind(2, p.position_m);
      prediction.bind(3, p.mean_if);
      prediction.bind(4, p.lower95);
      prediction.bind(5, p.upper95);
      prediction.bind(6, p.mean_lower95);
      prediction.bind(7, p.mean_upper95);
      prediction.run();
    }
    check_write_fault(path_);  // a test's full disk strikes before the commit: nothing lands
    execute(db_, "COMMIT;", path_, "commit");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK;", nullptr, nullptr, nullptr);
    throw;
  }
}

std::optional<std::uint64_t> HistoryDb::last_seq() const {
  Statement last(db_, "SELECT max(seq) FROM reports;", path_);
  if (!last.next() || last.null(0)) return std::nullopt;
  return static_cast<std::uint64_t>(last.integer(0));
}

records::HistoryReport HistoryDb::read_report(std::uint64_t seq) const {
  records::HistoryReport r;
  std::string stored_checksum, checkpoint_checksum;
  {
    Statement report(db_,
                     "SELECT trucks, time_s, source, lines_consumed, ess, checkpoint_checksum, row_checksum "
                     "FROM reports WHERE seq = ?;",
                     path_);
    report.bind(1, static_cast<std::int64_t>(seq));
    if (!report.next()) throw DataError(path_, 0, "reports", "no report number " + std::to_string(seq));
    r.seq = seq;
    r.trucks = report.integer(0);
    r.time_s = report.real(1);
    r.source = report.text(2);
    r.lines_consumed = static_cast<std::uint64_t>(report.integer(3));
    r.ess = report.real(4);
    checkpoint_checksum = report.text(5);
    stored_checksum = report.text(6);
  }
  r.checkpoint_checksum = std::strtoull(checkpoint_checksum.c_str(), nullptr, 16);
  {
    // rowid order is the order written, the one the checksum covers.
    Statement hyper(db_,
                    "SELECT class, name, mean, sd, q025, q975 FROM hyperparameters WHERE seq = ? ORDER BY rowid;",
                    path_);
    hyper.bind(1, static_cast<std::int64_t>(seq));
    while (hyper.next()) {
      r.hyperparameters.push_back(
          {hyper.text(0), hyper.text(1), hyper.real(2), hyper.real(3), hyper.real(4), hyper.real(5)});
    }
  }
  {
    Statement prediction(db_,
                         "SELECT position_m, mean_if, lower95, upper95, mean_lower95, mean_upper95 FROM predictions "
                         "WHERE seq = ? ORDER BY rowid;",
                         path_);
    prediction.bind(1, static_cast<std::int64_t>(seq));
    while (prediction.next()) {
      r.predictions.push_back({prediction.real(0), prediction.real(1), prediction.real(2), prediction.real(3),
                               prediction.real(4), prediction.real(5)});
    }
  }
  if (hex(history_row_checksum(r)) != stored_checksum) {
    throw DataError(path_, 0, "row_checksum",
                    "report " + std::to_string(seq) + " does not match its checksum: the history was changed or "
                    "damaged after it was written");
  }
  return r;
}

}  // namespace ssrfleet::io
