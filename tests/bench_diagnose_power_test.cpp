// The power campaign's bookkeeping (benchmarks/diagnose_power.hpp): which runs
// count as right, the runs file that lets a campaign stop and go on, the false-alarm verdict
// against the 5 % target, and the plot's script. A campaign runs for hours on these verdicts, so
// they are checked here on runs made up for the purpose, not on a campaign's output.
#include <catch2/catch.hpp>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "diagnose_power.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using bench::power::Run;

namespace {

Run run(const std::string& setting, int trucks, std::uint64_t seed, const std::string& named) {
  const std::string verdict = named == "none" ? "none" : (named == "unexplained" ? "unexplained" : "explained");
  return {setting, trucks, seed, named, verdict, 12.5, 256, "abc1234"};
}

// `alarms` of `clean` clean logs named something.
std::vector<Run> clean_logs(int clean, int alarms) {
  std::vector<Run> runs;
  for (int s = 0; s < clean; ++s)
    runs.push_back(run("none", 100, static_cast<std::uint64_t>(2001 + s), s < alarms ? "sensor_gain" : "none"));
  return runs;
}

std::string false_alarm_line(const std::vector<Run>& runs) {
  const std::string md = bench::power::tables(runs, {"none"}, {100}, "test");
  const auto at = md.find("**False alarms**");
  REQUIRE(at != std::string::npos);
  return md.substr(at);
}

}  // namespace

TEST_CASE("a run is right when it names its own effect first, and a clean log only when it names none", "[bench][power]") {
  CHECK(bench::power::right(run("sensor_gain:sensor=5,gain=1.02", 50, 101, "sensor_gain")));
  CHECK_FALSE(bench::power::right(run("sensor_gain:sensor=5,gain=1.02", 50, 101, "speed_bias")));
  CHECK_FALSE(bench::power::right(run("sensor_gain:sensor=5,gain=1.02", 50, 101, "none")));
  CHECK_FALSE(bench::power::right(run("sensor_gain:sensor=5,gain=1.02", 50, 101, "unexplained")));
  CHECK(bench::power::right(run("none", 100, 2001, "none")));
  // "unexplained" on a clean log is an alarm too: it says a gap is there.
  CHECK_FALSE(bench::power::right(run("none", 100, 2001, "unexplained")));
  CHECK_FALSE(bench::power::right(run("none", 100, 2001, "tyre_damping")));
}

TEST_CASE("an effect's size is its setting's last parameter", "[bench][power]") {
  CHECK(bench::power::size_of("sensor_gain:sensor=5,gain=1.05") == std::pair<std::string, double>{"gain", 1.05});
  CHECK(bench::power::size_of("second_class:share=0.3,sigma_k2=100000,K2=700000") ==
        std::pair<std::string, double>{"K2", 700000.0});
  CHECK(bench::power::size_of("tyre_damping:c_t=1000") == std::pair<std::string, double>{"c_t", 1000.0});
  CHECK(bench::power::size_of("none").first.empty());
  CHECK(bench::power::effect_of("speed_bias:factor=1.02") == "speed_bias");
}

TEST_CASE("the runs file gives back every run once, and skips a line a kill cut short", "[bench][power]") {
  test::TempDir dir;
  const std::string path = dir.file("runs.jsonl");
  const Run a = run("tyre_damping:c_t=2000", 400, 107, "tyre_damping");
  const Run b = run("none", 100, 2042, "none");
  bench::power::append_run(path, a);
  // A process killed while writing leaves a torn line between whole ones.
  {
    std::ofstream torn(path, std::ios::app);
    torn << "{\"setting\":\"speed_bias:factor=1.05\",\"trucks\":4\n";
  }
  bench::power::append_run(path, b);
  // The same run written twice (two processes given the same part) counts once, the first.
  Run again = a;
  again.named = "none";
  bench::power::append_run(path, again);
  const auto runs = bench::power::read_runs(path);
  REQUIRE(runs.size() == 2);
  CHECK(bench::power::key_of(runs[0]) == bench::power::key_of(a));
  CHECK(runs[0].named == "tyre_damping");
  CHECK(runs[0].verdict == "explained");
  CHECK(runs[0].wall_s == a.wall_s);
  CHECK(runs[0].particles == 256);
  CHECK(runs[0].commit == "abc1234");
  CHECK(bench::power::key_of(runs[1]) == bench::power::key_of(b));
}

TEST_CASE("the false-alarm verdict follows the rate and its Clopper-Pearson interval", "[bench][power]") {
  // 0 of 100: the interval is [0, 3.6] %, inside 5 %.
  CHECK_THAT(false_alarm_line(clean_logs(100, 0)), Catch::Contains("0 of 100") && Catch::Contains("met"));
  // 2 of 100: 2 % but the interval [0.2, 7.0] % reaches above 5 %.
  CHECK_THAT(false_alarm_line(clean_logs(100, 2)),
             Catch::Contains("[0.2, 7.0] %") && Catch::Contains("rate within 5 %, but the interval reaches above it"));
  // 6 of 100: over the target.
  CHECK_THAT(false_alarm_line(clean_logs(100, 6)), Catch::Contains("missed"));
  // 99 logs are too few to judge at all, whatever they say.
  CHECK_THAT(false_alarm_line(clean_logs(99, 0)), Catch::Contains("too few clean logs to judge"));
}

TEST_CASE("a detection cell counts its runs and names what was said instead", "[bench][power]") {
  std::vector<Run> runs;
  for (std::uint64_t s = 101; s <= 104; ++s) runs.push_back(run("speed_bias:factor=1.02", 50, s, s < 104 ? "speed_bias" : "none"));
  const std::string md = bench::power::tables(runs, {"speed_bias:factor=1.02"}, {50, 100}, "test");
  CHECK_THAT(md, Catch::Contains("| speed_bias:factor=1.02 | 3/4 ") && Catch::Contains("none 1, speed_bias 3"));
  // No run at 100 trucks: the cell says so rather than 0/0.
  CHECK_THAT(md, Catch::Contains("s) | - |"));
}

TEST_CASE("the plot's script puts a tic at each size run, written out whole", "[bench][power]") {
  test::TempDir dir;
  std::vector<Run> runs;
  for (const auto* setting : {"second_class:share=0.3,sigma_k2=100000,K2=700000",
                              "second_class:share=0.3,sigma_k2=100000,K2=1000000", "sensor_gain:sensor=5,gain=1.02"})
    runs.push_back(run(setting, 50, 101, "second_class"));
  for (auto& r : clean_logs(100, 2)) runs.push_back(r);
  bench::power::write_plot(dir.file("power"), runs, {50, 100});
  const std::string gp = test::read_text(dir.file("power.gp"));
  // gnuplot's own tics for K2 were 650000, 700000, ... and ran into each other.
  CHECK_THAT(gp, Catch::Contains("set xtics ('700000' 700000, '1000000' 1000000)"));
  CHECK_THAT(gp, Catch::Contains("set xtics ('1.02' 1.02"));
  const std::string csv = test::read_text(dir.file("power.csv"));
  CHECK_THAT(csv, Catch::Contains("second_class,K2,700000,50,1,1,1,"));
  CHECK_THAT(csv, Catch::Contains("sensor_gain,gain,1.02,50,0,1,0,"));
  // The clean logs are no effect's points; they get their own panel, against the 5 % target.
  CHECK_THAT(csv, !Catch::Contains("none"));
  const std::string alarms = test::read_text(dir.file("power-false-alarms.csv"));
  CHECK_THAT(alarms, Catch::StartsWith("trucks,alarms,logs,rate,lower95,upper95\n100,2,100,0.02,"));
  CHECK_THAT(gp, Catch::Contains("clean logs: false alarms") && Catch::Contains("first 0.05"));
}

TEST_CASE("a campaign runs the clean logs, then each fleet size in turn", "[bench][power]") {
  const auto runs = bench::power::campaign(2, 100, {400, 50}, {"a:x=1", "b:y=2"}, 3);
  REQUIRE(runs.size() == 2 + 2 * 2 * 3);
  CHECK(runs[0] == bench::power::Key{"none", 100, 2001});
  CHECK(runs[1] == bench::power::Key{"none", 100, 2002});
  CHECK(runs[2] == bench::power::Key{"a:x=1", 50, 101});
  CHECK(runs[5] == bench::power::Key{"b:y=2", 50, 101});
  // The smaller fleet first, whatever order the sizes were given in.
  CHECK(runs[8] == bench::power::Key{"a:x=1", 400, 101});
  CHECK(runs.back() == bench::power::Key{"b:y=2", 400, 103});
}

TEST_CASE("the shards of a campaign cover it once, and a run's shard does not move as runs get done", "[bench][power]") {
  const auto whole = bench::power::campaign(5, 100, {50, 100, 400}, {"a:x=1", "b:y=2", "c:z=3"}, 4);
  for (int shards : {1, 2, 3, 7}) {
    INFO(shards << " shards");
    std::map<bench::power::Key, int> taken;
    for (int k = 0; k < shards; ++k)
      for (const auto& key : bench::power::shard_of(whole, k, shards)) ++taken[key];
    CHECK(taken.size() == whole.size());
    CHECK(std::all_of(taken.begin(), taken.end(), [](const auto& kv) { return kv.second == 1; }));
  }
  // Shards split the whole list, not what is left of it: a process started after the other has
  // done some runs still takes the same part, so the two never run one log twice.
  const auto part = bench::power::shard_of(whole, 1, 2);
  CHECK(part[0] == whole[1]);
  CHECK(part[1] == whole[3]);
  CHECK(part.size() == whole.size() / 2);
}
