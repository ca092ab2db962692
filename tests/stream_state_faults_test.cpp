// The stream's state directory under write failures: a full disk at every
// single write the state depends on, then an exact resume; and the history database it keeps.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>

#include "fleet/posterior_summary.hpp"
#include "io/history_db.hpp"
#include "io/posterior_json.hpp"
#include "model/fleet_model.hpp"
#include "io/write_faults.hpp"
#include "site/road_source.hpp"
#include "stream/wim_stream.hpp"
#include "test_support.hpp"

using namespace ssrfleet;

namespace {

std::string q(const std::string& p) { return "'" + p + "'"; }

stream::StreamOptions small_stream(const std::string& state) {
  stream::StreamOptions o;
  o.state_dir = state;
  o.fit.sampler().particles = 64;
  o.fit.sampler().threads = 2;
  o.fit.sampler().seed = 4;
  o.history_prediction.theta_draws = 8;
  o.history_prediction.trucks_per_draw = 8;
  return o;
}

// Streams the whole log into `state`; an IoError (the injected full disk) propagates.
void stream_log(const site::Site& site, const std::string& state, const std::string& log) {
  std::ostringstream reports;
  stream::WimStream s(site, small_stream(state), nullptr, reports);
  std::ifstream in(log);
  const std::atomic<bool> stop{false};
  s.run(in, log, stop);
}

// Everything a history report says but the wall-clock time it was written.
void check_same_history(const std::string& a, const std::string& b) {
  const io::HistoryDb ha(a + "/history.sqlite", "base"), hb(b + "/history.sqlite", "base");
  REQUIRE(ha.last_seq() == hb.last_seq());
  for (std::uint64_t seq = 1; seq <= ha.last_seq().value_or(0); ++seq) {
    const auto ra = ha.read_report(seq), rb = hb.read_report(seq);
    INFO("report " << seq);
    CHECK(ra.trucks == rb.trucks);
    CHECK(ra.lines_consumed == rb.lines_consumed);
    CHECK(ra.checkpoint_checksum == rb.checkpoint_checksum);
    CHECK(ra.ess == rb.ess);
    REQUIRE(ra.hyperparameters.size() == rb.hyperparameters.size());
    for (std::size_t k = 0; k < ra.hyperparameters.size(); ++k) {
      CHECK(ra.hyperparameters[k].name == rb.hyperparameters[k].name);
      CHECK(ra.hyperparameters[k].mean == rb.hyperparameters[k].mean);
      CHECK(ra.hyperparameters[k].q975 == rb.hyperparameters[k].q975);
    }
    REQUIRE(ra.predictions.size() == rb.predictions.size());
    for (std::size_t k = 0; k < ra.predictions.size(); ++k) {
      CHECK(ra.predictions[k].mean_if == rb.predictions[k].mean_if);
      CHECK(ra.predictions[k].upper95 == rb.predictions[k].upper95);
    }
  }
}

struct FaultCase {
  test::TempDir dir;
  std::string log = dir.file("log.csv");
  site::Site site{site::load_road("AS1"), site::SiteOptions{}};
  FaultCase() {
    REQUIRE(test::run_ssrfleet("simulate --trucks 4 --seed 8 --quiet --out " + q(log), dir).status == 0);
    // One bad record, so the rejects list is among the writes that fail.
    std::string text = test::read_text(log);
    text.insert(text.find("\nT0003") + 1, "BAD1,oops,4000,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1\n");
    test::write_text(log, text);
  }
};

}  // namespace

TEST_CASE("a full disk at any one write of the stream's state leaves it resumable to the exact posterior and history",
          "[stream][faults]") {
  FaultCase c;
  const std::string reference = c.dir.file("reference");
  io::arm_write_fault(0);
  stream_log(c.site, reference, c.log);
  const int writes = io::write_operations_seen();
  // Per truck: the truck log (an append, or the whole log after a table rebuild), the checkpoint,
  // the history, posterior.json; and the rejected record.
  REQUIRE(writes == 4 * 4 + 1);
  for (int k = 1; k <= writes; ++k) {
    INFO("the write that fails: " << k << " of " << writes);
    const std::string state = c.dir.file("state" + std::to_string(k));
    io::arm_write_fault(k);
    bool failed = false;
    try {
      stream_log(c.site, state, c.log);
    } catch (const IoError& e) {
      failed = std::string(e.what()).find("No space left on device") != std::string::npos;
    }
    io::disarm_write_fault();
    REQUIRE(failed);
    // Space is back: the resume finishes the log.
    stream_log(c.site, state, c.log);
    CHECK(test::read_text(state + "/posterior.json") == test::read_text(reference + "/posterior.json"));
    CHECK(test::read_text(state + "/rejects.csv") == test::read_text(reference + "/rejects.csv"));
    CHECK(test::read_text(state + "/trucks.bin") == test::read_text(reference + "/trucks.bin"));
    CHECK_FALSE(std::filesystem::exists(state + "/trucks.bin.next"));
    check_same_history(state, reference);
  }
}

TEST_CASE("the history holds a report for every checkpoint, the posterior file's last, and refuses a damaged one",
          "[stream][history]") {
  FaultCase c;
  const std::string state = c.dir.file("state");
  stream_log(c.site, state, c.log);
  {
    const io::HistoryDb history(state + "/history.sqlite", "base");
    REQUIRE(history.last_seq() == 4u);  // one checkpoint per absorbed truck
    for (std::uint64_t seq = 1; seq <= 4; ++seq) {
      const auto r = history.read_report(seq);
      CHECK(r.trucks == static_cast<std::int64_t>(seq));
      CHECK(r.hyperparameters.size() == 7u);
      CHECK(r.predictions.size() == 16u);  // the AS1 site's sensors
      for (const auto& p : r.predictions) CHECK((p.lower95 < p.mean_if && p.mean_if < p.upper95));
    }
    // The last report's summaries are the posterior file's.
    const auto last = history.read_report(4);
    const auto cloud = io::read_posterior_file(state);
    CHECK(cloud.trucks_seen == 4);
    const auto summary = fleet::summarise_cloud(cloud);
    for (std::size_t k = 0; k < summary.size(); ++k) {
      CHECK(last.hyperparameters[k].name == fleet::kHyperNames[k]);
      CHECK(last.hyperparameters[k].mean == Approx(summary[k].mean).epsilon(1e-12));  // through JSON text
      CHECK(last.hyperparameters[k].q025 == Approx(summary[k].q025).epsilon(1e-12));
    }
  }
  // A model other than the state's is refused by name.
  CHECK_THROWS_AS(io::HistoryDb(state + "/history.sqlite", "sensor_gain"), DataError);
  // Cut at every 1 KiB offset (a bad copy): a DataError naming the file, never a resumed stream.
  const std::string good = test::read_text(state + "/history.sqlite");
  REQUIRE(good.size() > 4096);
  int refused = 0, cuts = 0;
  for (std::size_t at = 0; at < good.size(); at += 1024) {
    ++cuts;
    test::write_text(state + "/history.sqlite", good.substr(0, at));
    const auto cut = test::data_error([&] { stream_log(c.site, state, c.log); });
    INFO("cut at " << at << (cut ? cut->what() : " accepted"));
    CHECK(cut.has_value());
    if (cut) refused += cut->file() == state + "/history.sqlite";
  }
  CHECK(refused == cuts);
  test::write_text(state + "/history.sqlite", good);
  // A report changed behind the stream's back: the resume names the history and the report.
  const std::string edit = "sqlite3 " + q(state + "/history.sqlite") +
                           " \"UPDATE predictions SET mean_if = mean_if + 1e-9 WHERE seq = 4 AND rowid = "
                           "(SELECT min(rowid) FROM predictions WHERE seq = 4);\"";
  REQUIRE(std::system(edit.c_str()) == 0);
  const auto error = test::data_error([&] { stream_log(c.site, state, c.log); });
  REQUIRE(error.has_value());
  CHECK(error->file() == state + "/history.sqlite");
  CHECK(error->field() == "row_checksum");
  // Not a database at all: a DataError naming the file, not a crash.
  test::write_text(state + "/history.sqlite", std::string(8192, 'x'));
  std::filesystem::remove(state + "/history.sqlite-wal");
  std::filesystem::remove(state + "/history.sqlite-shm");
  const auto garbage = test::data_error([&] { stream_log(c.site, state, c.log); });
  REQUIRE(garbage.has_value());
  CHECK(garbage->file() == state + "/history.sqlite");
}
