#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <algorithm>
#include <cstdio>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <catch2/catch.hpp>

#include "io/csv_reader.hpp"
#include "io/posterior_json.hpp"
#include "test_support.hpp"

extern char** environ;

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

// Starts `ssrfleet args...` in the background with stdout and stderr to /dev/null.
pid_t spawn_ssrfleet(const std::vector<std::string>& args) {
  std::vector<std::string> all = {SSRFLEET_BINARY};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, SSRFLEET_BINARY, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  REQUIRE(rc == 0);
  return pid;
}

int wait_for(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

long trucks_in(const std::string& state_dir) {
  try {
    return io::read_posterior_file(state_dir).trucks_seen;
  } catch (const std::exception&) {
    return 0;
  }
}

std::vector<std::string> stream_args(const std::string& state, const std::string& log) {
  return {"stream", "--state", state, "--input", log, "--particles", "96", "--threads", "2", "--seed", "4", "--quiet"};
}
}  // namespace

TEST_CASE("a stream gives the same posterior as fit on the same log", "[cli][stream]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 10 --seed 8 --quiet --out " + q(log), dir).status == 0);
  // The stream keeps the cloud its stages leave; fit's final rejuvenation sweeps are off to match.
  REQUIRE(run_ssrfleet("fit " + q(log) + " --particles 96 --seed 4 --final-sweeps 0 --quiet --out " + q(dir.file("fit.json")),
                       dir)
              .status == 0);
  const auto r = run_ssrfleet("stream --state " + q(dir.file("state")) + " --input " + q(log) +
                                  " --particles 96 --seed 4 --quiet --report-every 5",
                              dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(test::read_text(dir.file("fit.json")) == test::read_text(dir.file("state") + "/posterior.json"));
  // Reports after 5 and 10 trucks (and the final one at the end of input).
  CHECK(r.out.find("# SSR prediction after 5 trucks") != std::string::npos);
  CHECK(r.out.find("# SSR prediction after 10 trucks") != std::string::npos);
  // Standard input works the same.
  const std::string cmd = std::string("'") + SSRFLEET_BINARY + "' stream --state " + q(dir.file("state3")) +
                          " --particles 96 --seed 4 --quiet < " + q(log) + " > /dev/null 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  CHECK(test::read_text(dir.file("fit.json")) == test::read_text(dir.file("state3") + "/posterior.json"));
}

TEST_CASE("a stream killed with SIGKILL at several points resumes to the bit-identical posterior", "[cli][stream][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 30 --seed 2 --quiet --out " + q(log), dir).status == 0);
  // Salt a few bad records in, so the rejects list is checked for duplicates too.
  std::string text = test::read_text(log);
  const auto pos = text.find("\nT0005");
  text.insert(pos + 1, "BAD1,oops,4000,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1\n");
  const auto pos2 = text.find("\nT0020");
  text.insert(pos2 + 1, "BAD2,20,4000,nan,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1\n");
  test::write_text(log, text);

  const std::string reference = dir.file("reference");
  REQUIRE(wait_for(spawn_ssrfleet(stream_args(reference, log))) == 0);
  REQUIRE(trucks_in(reference) == 30);

  const std::string state = dir.file("state");
  int kills = 0;
  for (long kill_after : {3L, 11L, 19L, 26L}) {
    const pid_t pid = spawn_ssrfleet(stream_args(state, log));
    // Let it absorb up to `kill_after` trucks, then kill it mid-work without warning.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (trucks_in(state) < kill_after && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    if (kill(pid, SIGKILL) == 0) ++kills;
    wait_for(pid);
  }
  CHECK(kills >= 3);
  REQUIRE(wait_for(spawn_ssrfleet(stream_args(state, log))) == 0);
  CHECK(trucks_in(state) == 30);
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(reference + "/posterior.json"));
  CHECK(test::read_text(state + "/rejects.csv") == test::read_text(reference + "/rejects.csv"));
}

TEST_CASE("a log salted with every kind of bad record absorbs exactly the good ones", "[cli][stream]") {
  test::TempDir dir;
  const std::string good = dir.file("good.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 8 --sensors 76,1.5,3 --seed 6 --quiet --out " + q(good), dir).status == 0);
  // A log with a time column, 3 sensors, the good records, and one bad record of each kind.
  std::ifstream in(good);
  std::string line, body;
  std::vector<std::string> good_rows;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("truck_id", 0) == 0) continue;
    const auto comma = line.find(',');
    good_rows.push_back(line.substr(0, comma) + ",0" + line.substr(comma));  // insert time_s
  }
  REQUIRE(good_rows.size() == 8);
  const std::vector<std::string> bad = {
      "B01,0,23,4400,1.0,1.0",              // too few columns
      "B02,0,23,4400,1.0,1.0,1.0,1.0",      // too many columns
      "B03,0,fast,4400,1.0,1.0,1.0",        // speed not a number
      "B04,0,nan,4400,1.0,1.0,1.0",         // speed NaN
      "B05,0,inf,4400,1.0,1.0,1.0",         // speed infinite
      "B06,0,-23,4400,1.0,1.0,1.0",         // speed negative
      "B07,0,0,4400,1.0,1.0,1.0",           // speed zero
      "B08,0,200,4400,1.0,1.0,1.0",         // speed impossible
      "B09,0,23,heavy,1.0,1.0,1.0",         // mass not a number
      "B10,0,23,NaN,1.0,1.0,1.0",           // mass NaN
      "B11,0,23,0,1.0,1.0,1.0",             // mass zero
      "B12,0,23,1e7,1.0,1.0,1.0",           // mass impossible
      "B13,0,23,4400,abc,1.0,1.0",          // IF not a number
      "B14,0,23,4400,1.0,nan,1.0",          // IF NaN
      "B15,0,23,4400,1.0,1.0,-0.5",         // IF negative
      "B16,0,23,4400,9.0,1.0,1.0",          // IF impossible
      "B17,0,23,4400,1.0,inf,1.0",          // IF infinite
      ",0,23,4400,1.0,1.0,1.0",             // empty truck_id
      "T0001,0,23,4400,1.0,1.0,1.0",        // duplicate truck_id (of a good one before it)
      "B20,0,,4400,1.0,1.0,1.0",            // empty speed
      "B21,0,23,4400,1.0,,1.0",             // empty IF
      "B22,noon,23,4400,1.0,1.0,1.0",       // time not a number
      "B23,0,23.4m/s,4400,1.0,1.0,1.0",     // speed with trailing junk
      "B24,0,23,4400,1.0,1.0,1e999",        // IF overflows
  };
  std::string text = "# salted\ntruck_id,time_s,speed_mps,sprung_mass_kg,if_1,if_2,if_3\n";
  for (std::size_t i = 0; i < good_rows.size(); ++i) {
    text += good_rows[i] + "\n";
    for (std::size_t b = i * 3; b < std::min(bad.size(), i * 3 + 3); ++b) text += bad[b] + "\n";
  }
  const std::string log = dir.file("salted.csv");
  test::write_text(log, text);
  const auto r = run_ssrfleet("stream --state " + q(dir.file("state")) + " --input " + q(log) +
                                  " --sensors 76,1.5,3 --particles 64 --seed 1",
                              dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(trucks_in(dir.file("state")) == 8);
  CHECK(r.err.find("8 trucks absorbed, 24 rejected") != std::string::npos);
  const std::string rejects = test::read_text(dir.file("state") + "/rejects.csv");
  for (const auto& b : bad) {
    INFO(b);
    CHECK(rejects.find("\n" + b + "\n") != std::string::npos);  // verbatim
  }
  CHECK(std::count(rejects.begin(), rejects.end(), '\n') == 2 + 2 * 24);  // header lines + reason and record each
  // Every rejection was reported on stderr with its line number.
  CHECK(r.err.find("salted.csv:4: field 'columns'") != std::string::npos);
}

TEST_CASE("predict reading the state of a running stream always gets a valid posterior", "[cli][stream][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 40 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const std::string state = dir.file("state");
  const pid_t pid = spawn_ssrfleet(stream_args(state, log));
  int reads = 0, bad_reads = 0;
  long last = 0;
  bool running = true;
  while (running) {
    running = waitpid(pid, nullptr, WNOHANG) == 0;
    if (!std::filesystem::exists(state + "/posterior.json")) continue;
    try {
      const auto cloud = io::read_posterior_file(state);
      CHECK(cloud.trucks_seen >= last);  // never goes back
      last = cloud.trucks_seen;
      ++reads;
    } catch (const std::exception& e) {
      ++bad_reads;
      FAIL_CHECK("read a broken posterior: " << e.what());
    }
  }
  INFO(reads << " reads while the stream ran");
  CHECK(reads > 10);
  CHECK(bad_reads == 0);
  CHECK(last == 40);
}

TEST_CASE("the sqlite3 shell reading a running stream's history always sees whole row sets", "[cli][stream][history][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 30 --seed 3 --quiet --out " + q(log), dir).status == 0);
  const std::string state = dir.file("state"), out = dir.file("query.txt");
  const pid_t pid = spawn_ssrfleet(stream_args(state, log));
  // Reports, their last seq, and prediction rows: a row set is all there or not at all.
  // A reader waits out the writer's brief locks (SQLite's busy timeout), as docs/streaming.md says to.
  const std::string query = "sqlite3 -cmd '.timeout 5000' " + q(state + "/history.sqlite") +
                            " 'SELECT count(*), coalesce(max(seq), 0), (SELECT count(*) FROM predictions), "
                            "(SELECT count(*) FROM hyperparameters) FROM reports;' > " + q(out) + " 2>&1";
  int reads = 0;
  long last = 0;
  bool running = true;
  while (running) {
    running = waitpid(pid, nullptr, WNOHANG) == 0;
    if (!std::filesystem::exists(state + "/history.sqlite")) continue;
    const int rc = std::system(query.c_str());
    const std::string text = test::read_text(out);
    long reports = -1, seq = -1, predictions = -1, hyper = -1;
    const bool parsed = std::sscanf(text.c_str(), "%ld|%ld|%ld|%ld", &reports, &seq, &predictions, &hyper) == 4;
    INFO("query output: " << text);
    REQUIRE(rc == 0);
    REQUIRE(parsed);
    CHECK(reports == seq);  // 1, 2, ..., seq: none missing
    CHECK(predictions == 16 * reports);
    CHECK(hyper == 7 * reports);
    CHECK(seq >= last);
    last = seq;
    ++reads;
  }
  INFO(reads << " reads while the stream ran");
  CHECK(reads > 5);
  CHECK(last == 30);
}

TEST_CASE("a following stream picks up records appended to its input and stops cleanly on SIGTERM",
          "[cli][stream]") {
  test::TempDir dir;
  const std::string full = dir.file("full.csv"), live = dir.file("live.csv"), state = dir.file("state");
  REQUIRE(run_ssrfleet("simulate --trucks 6 --seed 5 --quiet --out " + q(full), dir).status == 0);
  std::vector<std::string> lines;
  {
    std::ifstream in(full);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  REQUIRE(lines.size() == 8);  // comment, header, 6 trucks
  {
    std::ofstream out(live);
    for (int i = 0; i < 4; ++i) out << lines[static_cast<std::size_t>(i)] << "\n";
    out << lines[4].substr(0, 20);  // a record still being written
  }
  const pid_t pid = spawn_ssrfleet({"stream", "--state", state, "--input", live, "--follow", "--particles", "64",
                                    "--seed", "3", "--quiet"});
  const auto wait_trucks = [&](long n) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (trucks_in(state) < n && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return trucks_in(state);
  };
  CHECK(wait_trucks(2) == 2);
  {
    std::ofstream out(live, std::ios::app);
    out << lines[4].substr(20) << "\n" << lines[5] << "\n" << lines[6] << "\n" << lines[7] << "\n";
  }
  CHECK(wait_trucks(6) == 6);
  kill(pid, SIGTERM);
  CHECK(wait_for(pid) == 0);
  CHECK(test::read_text(state + "/rejects.csv").find("# line") == std::string::npos);  // the split record was whole
}

TEST_CASE("the stream checkpoint keeps its size while the truck log grows and a torn append is cut off on resume",
          "[cli][stream][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 40 --seed 5 --quiet --out " + q(log), dir).status == 0);
  // The first 20 trucks, then the whole log (the resume skips the 20 already absorbed).
  const std::string text = test::read_text(log);
  std::size_t cut = 0;
  for (int lines = 0; lines < 22; ++lines) cut = text.find('\n', cut) + 1;  // comment + header + 20 records
  const std::string half = dir.file("half.csv");
  test::write_text(half, text.substr(0, cut));

  const std::string state = dir.file("state");
  REQUIRE(wait_for(spawn_ssrfleet(stream_args(state, half))) == 0);
  REQUIRE(trucks_in(state) == 20);
  const auto checkpoint_20 = std::filesystem::file_size(state + "/checkpoint.bin");
  const auto trucks_20 = std::filesystem::file_size(state + "/trucks.bin");
  CHECK(trucks_20 > 20 * 100);  // a record is a truck's data and table: well over 100 bytes each

  // A crash after appending to the truck log but before the checkpoint: a torn tail.
  {
    std::ofstream torn(state + "/trucks.bin", std::ios::binary | std::ios::app);
    torn << std::string(777, '\x5a');
  }
  const std::string reference = dir.file("reference");
  REQUIRE(wait_for(spawn_ssrfleet(stream_args(reference, log))) == 0);
  REQUIRE(wait_for(spawn_ssrfleet(stream_args(state, log))) == 0);
  CHECK(trucks_in(state) == 40);
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(reference + "/posterior.json"));
  // The checkpoint holds no per-truck data: 40 trucks' checkpoint is the size of 20 trucks' (the
  // source name and counters are fixed-width; the two runs name different inputs, so allow that).
  const auto checkpoint_40 = std::filesystem::file_size(state + "/checkpoint.bin");
  CHECK(checkpoint_40 <= checkpoint_20 + 64);
  CHECK(std::filesystem::file_size(state + "/trucks.bin") > trucks_20);
  CHECK(test::read_text(state + "/trucks.bin") == test::read_text(reference + "/trucks.bin"));

  // A state written by ssrfleet 0.1 (its checkpoint began with the latent core's magic word) is
  // refused with a message naming its format version, and nothing is overwritten.
  const std::string old_state = dir.file("old");
  std::filesystem::create_directories(old_state);
  test::write_text(old_state + "/checkpoint.bin", std::string("SSRFCKPT\x01\0\0\0", 12) + std::string(64, '\0'));
  const auto r = run_ssrfleet("stream --state " + q(old_state) + " --input " + q(log) + " --particles 96 --quiet", dir);
  CHECK(r.status == 65);
  CHECK(r.err.find("format version 1") != std::string::npos);
  CHECK(r.err.find("checkpoint.bin") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(old_state + "/posterior.json"));
}

TEST_CASE("a stream fits a model, records it in its state, and refuses to resume with another", "[cli][stream][extension]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 6 --seed 8 --quiet --effect speed_bias:factor=1.1 --out " + q(log), dir).status == 0);
  // The same posterior as fit with the same model (fit's final sweeps off, as a stream has none).
  REQUIRE(run_ssrfleet("fit " + q(log) + " --model speed_bias --particles 64 --seed 4 --final-sweeps 0 --quiet --out " +
                           q(dir.file("fit.json")), dir)
              .status == 0);
  const std::string state = dir.file("state");
  const auto r = run_ssrfleet("stream --state " + q(state) + " --input " + q(log) +
                                  " --model speed_bias --particles 64 --seed 4 --quiet", dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(test::read_text(dir.file("fit.json")) == test::read_text(state + "/posterior.json"));
  CHECK(test::read_text(state + "/posterior.json").find("\"model\": \"speed_bias\"") != std::string::npos);
  // A resume with the same model skips what it has; another model is refused, the state untouched.
  const std::string before = test::read_text(state + "/posterior.json");
  const auto same = run_ssrfleet("stream --state " + q(state) + " --input " + q(log) +
                                     " --model speed_bias --particles 64 --seed 4 --quiet", dir);
  CHECK(same.status == 0);
  const auto other = run_ssrfleet("stream --state " + q(state) + " --input " + q(log) + " --particles 64 --seed 4 --quiet", dir);
  CHECK(other.status != 0);
  CHECK(other.err.find("the state was written with --model speed_bias") != std::string::npos);
  CHECK(test::read_text(state + "/posterior.json") == before);
  // The bounded-memory window is gone: a usage error that says what to do instead, and no state.
  for (const char* window : {" --window 3", " --window=3"}) {
    const auto windowed = run_ssrfleet("stream --state " + q(dir.file("w")) + " --input " + q(log) + window + " --quiet", dir);
    CHECK(windowed.status == 64);
    CHECK(windowed.err.find("--window is not an option of stream") != std::string::npos);
    CHECK(windowed.err.find("drop --window") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(dir.file("w")));
    const auto fit = run_ssrfleet("fit " + q(log) + window + " --out " + q(dir.file("w.json")), dir);
    CHECK(fit.status == 64);
    CHECK(fit.err.find("--window is not an option of fit") != std::string::npos);
  }
}

TEST_CASE("a second stream on a live state exits at once with status 75 and the first goes on unharmed",
          "[cli][stream]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv"), state = dir.file("state");
  REQUIRE(run_ssrfleet("simulate --trucks 6 --seed 5 --quiet --out " + q(log), dir).status == 0);
  const pid_t first = spawn_ssrfleet({"stream", "--state", state, "--input", log, "--follow", "--particles", "64",
                                      "--seed", "3", "--quiet"});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (trucks_in(state) < 6 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  REQUIRE(trucks_in(state) == 6);
  const std::string before = test::read_text(state + "/posterior.json");
  const auto second = run_ssrfleet("stream --state " + q(state) + " --input " + q(log) + " --particles 64 --seed 3", dir);
  CHECK(second.status == 75);
  CHECK(second.err.find("is in use by another stream (process " + std::to_string(first) + ")") != std::string::npos);
  CHECK(test::read_text(state + "/posterior.json") == before);  // the second wrote nothing
  // The first is still running and stops cleanly.
  CHECK(kill(first, 0) == 0);
  kill(first, SIGTERM);
  CHECK(wait_for(first) == 0);
  // Killed with SIGKILL while holding the lock, a stream leaves a state that resumes at once:
  // the kernel dropped its lock.
  const pid_t killed = spawn_ssrfleet({"stream", "--state", state, "--input", log, "--follow", "--particles", "64",
                                       "--seed", "3", "--quiet"});
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(killed, SIGKILL);
  CHECK(wait_for(killed) == -SIGKILL);
  const auto resumed = run_ssrfleet("stream --state " + q(state) + " --input " + q(log) + " --particles 64 --seed 3", dir);
  INFO(resumed.err);
  CHECK(resumed.status == 0);
  CHECK(resumed.err.find("6 trucks in the posterior") != std::string::npos);
}

TEST_CASE("a truncated or damaged state file is refused by name and never gives a posterior", "[cli][stream][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv"), state = dir.file("state");
  REQUIRE(run_ssrfleet("simulate --trucks 4 --seed 5 --quiet --out " + q(log), dir).status == 0);
  REQUIRE(run_ssrfleet("stream --state " + q(state) + " --input " + q(log) + " --particles 32 --seed 3 --quiet", dir).status == 0);
  const std::string posterior = test::read_text(state + "/posterior.json");
  for (const char* name : {"checkpoint.bin", "trucks.bin"}) {
    const std::string path = state + "/" + name;
    const std::string good = test::read_text(path);
    REQUIRE(good.size() > 2048);
    const auto resume = [&] {
      return run_ssrfleet("stream --state " + q(state) + " --input " + q(log) + " --particles 32 --seed 3 --quiet", dir);
    };
    const auto write = [&](const std::string& bytes) {
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out << bytes;
    };
    // Cut at every 1 KiB offset: a clear error naming the file (the truck log's tail beyond the
    // checkpoint's count is cut off by design, so only cuts inside what the checkpoint counts
    // matter there: all of them, since the checkpoint counts every record).
    int refused = 0, cuts = 0;
    for (std::size_t at = 0; at < good.size(); at += 1024) {
      ++cuts;
      write(good.substr(0, at));
      const auto r = resume();
      INFO(name << " cut at " << at << ": " << r.err);
      CHECK(r.status == 65);
      CHECK(r.err.find(name) != std::string::npos);
      refused += r.status == 65;
      CHECK(test::read_text(state + "/posterior.json") == posterior);  // nothing overwritten
    }
    CHECK(refused == cuts);
    // One flipped byte in the middle (a value, not a length): the checksum names it.
    std::string damaged = good;
    damaged[damaged.size() / 2] = static_cast<char>(damaged[damaged.size() / 2] ^ 0x10);
    write(damaged);
    const auto r = resume();
    INFO(r.err);
    CHECK(r.status == 65);
    CHECK(r.err.find(name) != std::string::npos);
    CHECK(test::read_text(state + "/posterior.json") == posterior);
    write(good);
  }
  // posterior.json, the file predict and a user's tools read: cut at every 1 KiB offset or with a
  // digit changed (still valid JSON), predict refuses it by name (exit 65) and prints nothing.
  {
    const std::string path = state + "/posterior.json";
    const auto predict = [&] { return run_ssrfleet("predict --posterior " + q(state) + " --quiet", dir); };
    int cuts = 0, refused = 0;
    for (std::size_t at = 0; at < posterior.size(); at += 1024) {
      ++cuts;
      test::write_text(path, posterior.substr(0, at));
      const auto r = predict();
      INFO("posterior.json cut at " << at << ": " << r.err);
      CHECK(r.err.find("posterior.json") != std::string::npos);
      CHECK(r.out.empty());
      refused += r.status == 65;
    }
    CHECK(refused == cuts);
    std::string damaged = posterior;
    const std::size_t digit = damaged.find_first_of("123456789", damaged.find("\"weights\""));
    REQUIRE(digit != std::string::npos);
    damaged[digit] = static_cast<char>(damaged[digit] ^ 0x01);  // another digit: another weight
    test::write_text(path, damaged);
    const auto r = predict();
    INFO(r.err);
    CHECK(r.status == 65);
    CHECK(r.err.find("checksum") != std::string::npos);
    test::write_text(path, posterior);
    CHECK(predict().status == 0);
  }
  // Restored, the state resumes.
  CHECK(run_ssrfleet("stream --state " + q(state) + " --input " + q(log) + " --particles 32 --seed 3 --quiet", dir).status == 0);
}
