// ssrfleet damage, weigh and simulate --forces end to end: the exact
// headers, the options, and bad input refused with file, line and field and a non-zero status.
#include <algorithm>
#include <filesystem>
#include <sstream>

#include <catch2/catch.hpp>

#include "io/csv_reader.hpp"
#include "io/gnuplot_runner.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& path) { return "'" + path + "'"; }

std::vector<io::CsvRow> csv_rows(const std::string& text) {
  std::istringstream in(text);
  io::CsvReader csv(in, "output");
  std::vector<io::CsvRow> rows;
  io::CsvRow row;
  while (csv.next(row)) rows.push_back(row);
  return rows;
}

// A small fitted posterior (6 trucks, 64 particles) on AS1's default site, fitted once and shared
// by the cases (each section of a case would otherwise fit again).
struct Fitted {
  test::TempDir dir;
  std::string log = dir.file("log.csv"), posterior = dir.file("post.json");
  Fitted() {
    REQUIRE(run_ssrfleet("simulate --trucks 6 --seed 3 --quiet --out " + q(log), dir).status == 0);
    REQUIRE(run_ssrfleet("fit " + q(log) + " --particles 64 --seed 9 --quiet --out " + q(posterior), dir).status == 0);
  }
};
const Fitted& fitted() {
  static const Fitted shared;
  return shared;
}
}  // namespace

TEST_CASE("damage writes the issue's columns at the sensors, with further powers, hot spots and a plot", "[cli]") {
  const Fitted& f = fitted();
  const std::string out = f.dir.file("damage.csv"), png = f.dir.file("damage.png");
  const auto r = run_ssrfleet("damage --posterior " + q(f.posterior) + " --out " + q(out) + " --power 2 --power 6 --draws 20 " +
                                  "--trucks-per-draw 10 --png " + q(png) + " --quiet",
                              f.dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  const auto rows = csv_rows(test::read_text(out));
  REQUIRE(rows.size() == 17);
  CHECK(rows[0].raw ==
        "position_m,dlc,a1,a1_q025,a1_q975,a4,a4_q025,a4_q975,a2,a2_q025,a2_q975,a6,a6_q025,a6_q975,hot_spot");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    std::vector<double> v;
    for (const auto& field : rows[i].fields) v.push_back(io::parse_finite(field, "damage", rows[i].line, "x"));
    CHECK(v[1] > 0.0);                               // a DLC
    CHECK(v[6] <= v[5] + 1e-12);                     // a4 limits around a4
    CHECK(v[5] <= v[7] + 1e-12);
    CHECK(v[5] >= v[2] * v[2] * v[2] * v[2] - 1e-9);  // Jensen: E[IF^4] >= E[IF]^4
    CHECK((v[14] == 0.0 || v[14] == 1.0));
  }
  // The summary in equivalent standard axles goes to standard output.
  CHECK(r.out.find("expected damage per million trucks") != std::string::npos);
  CHECK(r.out.find("static (no dynamics)") != std::string::npos);
  if (io::gnuplot_available()) CHECK(std::filesystem::file_size(png) > 1000);
  CHECK(std::filesystem::exists(f.dir.file("damage.gp")));

  // Any positions; a stream's state directory (its posterior.json) in place of the file.
  const std::string state = f.dir.file("state");
  std::filesystem::create_directories(state);
  std::filesystem::copy_file(f.posterior, state + "/posterior.json", std::filesystem::copy_options::overwrite_existing);
  const auto anywhere = run_ssrfleet("damage --posterior " + q(state) + " --positions 80:0.5:82 --draws 10 --trucks-per-draw 5 --quiet", f.dir);
  INFO(anywhere.err);
  REQUIRE(anywhere.status == 0);
  CHECK(csv_rows(anywhere.out).size() == 6);
  CHECK(anywhere.err.find("expected damage per million trucks") != std::string::npos);  // the CSV took stdout

  // Usage errors: --state (a stream's option: a state directory is read with --posterior), a power
  // asked twice, a bad threshold, another site by accident.
  for (const char* state_option : {" --state ", " --state="}) {
    const auto state_given = run_ssrfleet("damage --posterior " + q(f.posterior) + state_option + q(state), f.dir);
    CHECK(state_given.status == 64);
    CHECK(state_given.err.find("--posterior DIR") != std::string::npos);
  }
  CHECK(run_ssrfleet("damage --posterior " + q(f.posterior) + " --power 4", f.dir).status == 64);
  CHECK(run_ssrfleet("damage --posterior " + q(f.posterior) + " --threshold -1", f.dir).status == 64);
  const auto other = run_ssrfleet("damage --posterior " + q(f.posterior) + " --road AS2", f.dir);
  CHECK(other.status == 64);
  CHECK(other.err.find("--new-road") != std::string::npos);
  CHECK(run_ssrfleet("damage --posterior " + q(f.dir.file("nowhere")), f.dir).status == 66);
}

TEST_CASE("simulate writes a force log and the true static weights, and weigh estimates them", "[cli]") {
  const Fitted& f = fitted();
  const std::string forces = f.dir.file("forces.csv"), truth = f.dir.file("truth.csv"), weights = f.dir.file("weights.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 5 --seed 12 --forces --no-sprung-mass --static-weights " + q(truth) +
                           " --quiet --out " + q(forces),
                       f.dir)
              .status == 0);
  const auto log_rows = csv_rows(test::read_text(forces));
  REQUIRE(log_rows.size() == 6);
  CHECK(log_rows[0].raw.rfind("truck_id,speed_mps,force_1,force_2,", 0) == 0);
  CHECK(log_rows[0].raw.find("sprung_mass_kg") == std::string::npos);
  const auto truth_rows = csv_rows(test::read_text(truth));
  REQUIRE(truth_rows.size() == 6);
  CHECK(truth_rows[0].raw == "truck_id,static_kn,sprung_mass_kg");

  const auto r = run_ssrfleet("weigh " + q(forces) + " --posterior " + q(f.posterior) + " --draws 20 --out " + q(weights), f.dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("fixed-point steps per truck") != std::string::npos);
  const auto rows = csv_rows(test::read_text(weights));
  REQUIRE(rows.size() == 6);
  CHECK(rows[0].raw == "truck_id,static_kn,static_kn_q025,static_kn_q975");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    CHECK(rows[i].fields[0] == truth_rows[i].fields[0]);
    const double est = io::parse_finite(rows[i].fields[1], "w", i, "static_kn");
    const double lo = io::parse_finite(rows[i].fields[2], "w", i, "q025"), hi = io::parse_finite(rows[i].fields[3], "w", i, "q975");
    const double t = io::parse_finite(truth_rows[i].fields[1], "t", i, "static_kn");
    CHECK(lo < est);
    CHECK(est < hi);
    CHECK(std::abs(est / t - 1.0) < 0.05);  // AS1 with 16 sensors: errors of about 1 %
  }
  // The log with the sprung mass column reads too (weigh does not use it).
  REQUIRE(run_ssrfleet("simulate --trucks 2 --seed 12 --forces --quiet --out " + q(forces), f.dir).status == 0);
  CHECK(test::read_text(forces).find("sprung_mass_kg") != std::string::npos);
  CHECK(run_ssrfleet("weigh " + q(forces) + " --posterior " + q(f.posterior) + " --draws 10 --quiet", f.dir).status == 0);
  CHECK(run_ssrfleet("simulate --trucks 2 --no-sprung-mass --quiet", f.dir).status == 64);
}

TEST_CASE("weigh refuses bad force logs with file, line and field, and writes nothing", "[cli]") {
  const Fitted& f = fitted();
  const std::string bad = f.dir.file("bad.csv"), out = f.dir.file("refused.csv");
  std::string header = "truck_id,speed_mps";
  std::string good_row = "A,22";
  for (int m = 1; m <= 16; ++m) {
    header += ",force_" + std::to_string(m);
    good_row += ",47000";
  }
  const auto weigh_bad = [&](const std::string& text) {
    test::write_text(bad, text);
    const auto r = run_ssrfleet("weigh " + q(bad) + " --posterior " + q(f.posterior) + " --draws 10 --quiet --out " + q(out), f.dir);
    CHECK(r.status == 65);
    CHECK_FALSE(std::filesystem::exists(out));
    return r.err;
  };
  SECTION("a negative force") {
    std::string row = good_row;
    row.replace(row.rfind(",47000"), 6, ",-5");
    CHECK(weigh_bad(header + "\n" + good_row + "\n" + "B" + row.substr(1) + "\n").find(bad + ":3: field 'force_16'") !=
          std::string::npos);
  }
  SECTION("a non-numeric force") {
    std::string row = good_row;
    row.replace(row.find(",47000"), 6, ",n/a");
    CHECK(weigh_bad(header + "\n" + row + "\n").find(bad + ":2: field 'force_1': 'n/a' is not a number") != std::string::npos);
  }
  SECTION("fewer sensors than the posterior's site") {
    const auto err = weigh_bad("truck_id,speed_mps,force_1,force_2\nA,22,47000,47000\n");
    CHECK(err.find(bad + ":1: field 'force_3'") != std::string::npos);
    CHECK(err.find("2 force columns but the posterior's site has 16 sensors (--sensors 76,1.5,16)") != std::string::npos);
  }
  SECTION("a missing column") {
    std::string h = header;
    h.replace(h.find(",speed_mps"), 10, "");
    std::string row = good_row;
    row.replace(row.find(",22"), 3, "");
    CHECK(weigh_bad(h + "\n" + row + "\n").find(bad + ":1: field 'speed_mps': required column is missing") != std::string::npos);
  }
  SECTION("an impact-factor log") { CHECK(weigh_bad(test::read_text(f.log)).find("field 'force_1'") != std::string::npos); }
  SECTION("forces far too small for a truck") {
    std::string row = "A,22";
    for (int m = 1; m <= 16; ++m) row += ",3000";
    CHECK(weigh_bad(header + "\n" + row + "\n").find(bad + ":2: field 'force_1'") != std::string::npos);
  }
}
