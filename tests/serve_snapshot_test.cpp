// The snapshot reader under a writer: every snapshot is one whole checkpoint (its rows verified
// against their checksum), the history is thinned to the points asked for, a checkpoint is found
// by its truck count, and the lock holder is found through /proc/locks without opening the lock.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <thread>

#include <catch2/catch.hpp>

#include "io/history_db.hpp"
#include "serve/rejects_tail.hpp"
#include "serve/served_state.hpp"
#include "serve/state_reader.hpp"
#include "serve/stream_status.hpp"
#include "test_support.hpp"

using namespace ssrfleet;

namespace {
records::HistoryReport report(std::uint64_t seq) {
  records::HistoryReport r;
  r.seq = seq;
  r.trucks = static_cast<std::int64_t>(seq) + 10;  // as a resumed state: 10 trucks before its first report
  r.time_s = 1.7e9 + static_cast<double>(seq);     // one truck a second
  r.source = "log.csv";
  r.lines_consumed = seq + 12;
  r.ess = 500.0;
  r.checkpoint_checksum = seq * 7919;
  for (const char* name : {"K", "sigma_k", "Kt", "sigma_kt", "Z", "sigma_z", "sigma_if"}) {
    r.hyperparameters.push_back({"", name, static_cast<double>(seq), 1.0, seq - 1.0, seq + 1.0});
  }
  for (int i = 0; i < 16; ++i) r.predictions.push_back({76.0 + 1.5 * i, 1.0, 0.9, 1.1, 0.99, 1.01});
  return r;
}
}  // namespace

TEST_CASE("serve snapshot: whole checkpoints while a writer commits, and the history thinned", "[serve]") {
  test::TempDir dir;
  const std::string path = dir.file("history.sqlite");
  serve::StateReader reader(path);
  CHECK_FALSE(reader.last_seq().has_value());  // no database yet: nothing, and nothing created
  CHECK_FALSE(std::filesystem::exists(path));
  io::HistoryDb db(path, "base");
  db.append(report(1));
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t seq = 2; seq <= 400; ++seq) db.append(report(seq));
    done = true;
  });
  std::uint64_t last = 0;
  int reads = 0;
  while (!done || reads == 0) {
    const auto snap = reader.snapshot();  // throws on a report whose rows do not match it
    REQUIRE(snap.has_value());
    CHECK(snap->report.seq >= last);
    last = snap->report.seq;
    CHECK(snap->report.trucks == static_cast<std::int64_t>(last) + 10);
    CHECK(snap->report.hyperparameters.size() == 7);
    CHECK(snap->report.hyperparameters[0].mean == static_cast<double>(last));
    CHECK(snap->report.predictions.size() == 16);
    CHECK(snap->classes == std::vector<std::string>{""});
    ++reads;
  }
  writer.join();
  const auto snap = reader.snapshot();
  REQUIRE(snap);
  CHECK(snap->report.seq == 400);
  CHECK(snap->model == "base");
  // The minute before the last report: reports 340..400 (one a second), 60 trucks in 60 s.
  CHECK(snap->report.trucks - snap->window_trucks == 60);
  CHECK(snap->report.time_s - snap->window_time_s == Approx(60.0));
  CHECK(reader.seq_of_trucks(110) == 100u);
  CHECK_FALSE(reader.seq_of_trucks(5).has_value());

  serve::HistoryQuery q;
  q.max_seq = 300;  // nothing after the snapshot's checkpoint, even though 400 exist
  q.points = 50;
  const auto all = reader.history(q);
  REQUIRE(all.size() == 7);
  CHECK(all[6].name == "sigma_if");
  const auto& t = all[0].trucks;
  // Trucks 11..310: a step of ceil(299 / 48) = 7 from 11 gives 43 points, and 310 closes the range.
  CHECK(t.size() == 44);
  CHECK(t[1] - t[0] == 7);
  CHECK(t.front() == 11);  // trucks start at 11: from = 1 is clamped to what exists
  CHECK(t.back() == 310);
  for (std::size_t i = 1; i < t.size(); ++i) CHECK(t[i] > t[i - 1]);
  q.name = std::string("Z");
  q.from_trucks = 100;
  q.to_trucks = 104;
  const auto z = reader.history(q);
  REQUIRE(z.size() == 1);
  CHECK(z[0].trucks == std::vector<std::int64_t>{100, 101, 102, 103, 104});
  CHECK(z[0].mean[0] == 90.0);  // trucks 100 is report 90
}

TEST_CASE("serve snapshot: a report changed after it was written is refused by name", "[serve]") {
  test::TempDir dir;
  const std::string path = dir.file("history.sqlite");
  {
    io::HistoryDb db(path, "base");
    db.append(report(1));
  }
  REQUIRE(std::system(("sqlite3 '" + path + "' \"UPDATE predictions SET mean_if = 2 WHERE position_m = 76;\"")
                          .c_str()) == 0);
  serve::StateReader reader(path);
  const auto error = test::data_error([&] { reader.snapshot(); });
  REQUIRE(error);
  CHECK(error->field() == "row_checksum");
}

TEST_CASE("serve status: the lock's holder seen through /proc/locks, then gone", "[serve]") {
  test::TempDir dir;
  CHECK_FALSE(serve::lock_state(dir.path().string()).lock_file);
  const std::string lock = dir.file("lock");
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT, 0644);
  REQUIRE(fd >= 0);
  REQUIRE(::flock(fd, LOCK_EX | LOCK_NB) == 0);
  const serve::LockState held = serve::lock_state(dir.path().string());
  CHECK(held.lock_file);
  CHECK(held.pid == static_cast<long>(::getpid()));
  ::close(fd);  // the lock goes with its descriptor, as when a stream exits
  const serve::LockState gone = serve::lock_state(dir.path().string());
  CHECK(gone.lock_file);
  CHECK_FALSE(gone.pid.has_value());
}

TEST_CASE("serve rejects: counted incrementally, and again when a resume cuts the file", "[serve]") {
  test::TempDir dir;
  const std::string path = dir.file("rejects.csv");
  serve::RejectsTail tail(path);
  tail.refresh();
  CHECK(tail.total() == 0);
  std::string text =
      "# records rejected by ssrfleet stream, verbatim, each after its reason\ntruck_id,speed_mps\n";
  for (int i = 0; i < 3000; ++i)
    text += "# line " + std::to_string(i + 3) + ": speed_mps: bad\nT" + std::to_string(i) + ",99\n";
  test::write_text(path, text);
  tail.refresh();
  CHECK(tail.total() == 3000);
  const auto last = tail.last(5);
  REQUIRE(last.size() == 5);
  CHECK(last.back().line == 3002);
  CHECK(last.back().record == "T2999,99");
  std::ofstream(path, std::ios::app)
      << "# line 9999: truck_id: duplicate\nT1,1\n# line 10000: spe";  // half a line
  tail.refresh();
  CHECK(tail.total() == 3001);
  CHECK(tail.last(1)[0].line == 9999);
  std::filesystem::resize_file(path, text.size() / 2);  // a resume cut it back
  tail.refresh();
  CHECK(tail.total() < 3000);
  CHECK(tail.total() > 1000);
}

TEST_CASE("serve answers cache: only the checkpoint's own answer comes back, older ones go", "[serve]") {
  test::TempDir dir;
  serve::ServedState state({"s", dir.path().string(), {}});
  state.store_answer("points=300", 5, std::make_shared<const std::string>("five"));
  REQUIRE(state.cached_answer("points=300", 5));
  CHECK(*state.cached_answer("points=300", 5) == "five");
  CHECK(state.cached_answer("points=300", 6) == nullptr);  // the stream moved on: ask the database
  CHECK(state.cached_answer("points=10", 5) == nullptr);
  state.store_answer("points=10", 6, std::make_shared<const std::string>("six"));
  CHECK(state.cached_answer("points=300", 5) == nullptr);  // dropped with its checkpoint
  for (int i = 0; i < 40; ++i) {
    std::string key(1, 'q');
    key.append(std::to_string(i));
    state.store_answer(key, 6, std::make_shared<const std::string>("x"));
  }
  CHECK(state.cached_answer("q39", 6) == nullptr);  // at most 16 kept
  CHECK(*state.cached_answer("points=10", 6) == "six");
}
