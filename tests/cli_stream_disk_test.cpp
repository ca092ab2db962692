// The stream on a real full disk and a real read-only one: a small tmpfs that
// fills up mid-stream, then the same tmpfs remounted read-only. Mounting needs root (CI runs as
// root); elsewhere the test says so and stops, and stream_state_faults_test.cpp, which injects the
// same failures at every write, still runs.
#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include <catch2/catch.hpp>

#include "io/posterior_json.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

// A tmpfs mounted on `dir` for the test's life.
class SmallDisk {
 public:
  SmallDisk(const std::string& dir, const std::string& size) : dir_(dir) {
    std::filesystem::create_directories(dir);
    mounted_ = std::system(("mount -t tmpfs -o size=" + size + " tmpfs " + q(dir) + " 2>/dev/null").c_str()) == 0;
  }
  ~SmallDisk() {
    if (mounted_) [[maybe_unused]] const int rc = std::system(("umount -l " + q(dir_)).c_str());
  }
  bool mounted() const { return mounted_; }
  bool remount(const std::string& options) const {
    return std::system(("mount -o remount," + options + " " + q(dir_)).c_str()) == 0;
  }

 private:
  std::string dir_;
  bool mounted_ = false;
};

std::string stream_cmd(const std::string& state, const std::string& log) {
  return "stream --state " + q(state) + " --input " + q(log) + " --particles 96 --seed 4 --quiet";
}
}  // namespace

TEST_CASE("a stream on a disk that fills up, then on a read-only one, stops with a clear error and resumes exactly",
          "[cli][stream][faults][heavy]") {
  test::TempDir dir;
  const std::string log30 = dir.file("log30.csv"), log40 = dir.file("log40.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 40 --seed 6 --quiet --out " + q(log40), dir).status == 0);
  {
    // The first 30 trucks (header and comment lines kept).
    const std::string text = test::read_text(log40);
    test::write_text(log30, text.substr(0, text.find("\nT0031") + 1));
  }
  const std::string reference30 = dir.file("reference30"), reference40 = dir.file("reference40");
  REQUIRE(run_ssrfleet(stream_cmd(reference30, log30), dir).status == 0);
  REQUIRE(run_ssrfleet(stream_cmd(reference40, log40), dir).status == 0);

  // The 30 trucks' state takes about 430 KiB when the stream ends; while it runs, the history's
  // write-ahead log and the spill files of its tables, data and ids (unnamed files in the state
  // directory, model/table_store.hpp) take about 900 KiB more. 600 KiB fills up after about 10 trucks.
  const SmallDisk disk(dir.file("disk"), "600k");
  if (!disk.mounted()) {
    WARN("cannot mount a tmpfs (needs root): the real full disk is not tried here");
    return;
  }
  const std::string state = dir.file("disk") + "/state";
  const auto full = run_ssrfleet(stream_cmd(state, log30), dir);
  INFO(full.err);
  CHECK(full.status == 74);
  CHECK(full.err.find(state) != std::string::npos);
  const bool says_full = full.err.find("No space left") != std::string::npos ||
                         full.err.find("disk full") != std::string::npos ||
                         full.err.find("disk is full") != std::string::npos;
  CHECK(says_full);
  // The last good state: a valid posterior of the trucks absorbed before the disk filled.
  const long absorbed = io::read_posterior_file(state).trucks_seen;
  CHECK(absorbed > 0);
  CHECK(absorbed < 30);

  // Space is back: the resume finishes the log, to the bit-identical posterior and history.
  REQUIRE(disk.remount("size=64m"));
  const auto resumed = run_ssrfleet(stream_cmd(state, log30), dir);
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(reference30 + "/posterior.json"));
  CHECK(test::read_text(state + "/trucks.bin") == test::read_text(reference30 + "/trucks.bin"));

  // Read-only: the next run stops at once, naming the state, and changes nothing.
  REQUIRE(disk.remount("ro"));
  const auto read_only = run_ssrfleet(stream_cmd(state, log40), dir);
  INFO(read_only.err);
  CHECK(read_only.status == 74);
  CHECK(read_only.err.find(state) != std::string::npos);
  CHECK(read_only.err.find("Read-only file system") != std::string::npos);
  REQUIRE(disk.remount("rw"));
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(reference30 + "/posterior.json"));
  const auto more = run_ssrfleet(stream_cmd(state, log40), dir);
  INFO(more.err);
  REQUIRE(more.status == 0);
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(reference40 + "/posterior.json"));
  // The history: one report per checkpoint, the same rows as the uninterrupted run's (whose
  // checkpoints differ from these only in the input file they name).
  const auto query = [&](const std::string& db) {
    const std::string out = dir.file("query.txt");
    const std::string cmd = "sqlite3 " + q(db) +
                            " 'SELECT r.seq, r.trucks, p.position_m, p.mean_if, p.upper95 FROM "
                            "reports r JOIN predictions p USING (seq) ORDER BY r.seq, p.position_m;' > " + q(out);
    REQUIRE(std::system(cmd.c_str()) == 0);
    return test::read_text(out);
  };
  const std::string history = query(state + "/history.sqlite");
  CHECK(history == query(reference40 + "/history.sqlite"));
  CHECK(std::count(history.begin(), history.end(), '\n') == 40 * 16);
}
