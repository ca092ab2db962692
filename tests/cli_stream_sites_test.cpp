// A stream of several sites, one fleet (issue 21 items 1 and 6): `stream --sites M` reads one input
// whose `site` column names each record's site, quarantines a record of no or an unknown site, keeps
// truck ids per site, resumes exactly, refuses a resume with other sites, and reads a state of one
// site written before states named their sites.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/joint_sites.hpp"
#include "io/csv_reader.hpp"
#include "io/history_db.hpp"
#include "io/posterior_json.hpp"
#include "test_support.hpp"
#include "util/binary_io.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

// Two sites (16 and 8 sensors), 12 trucks each, simulated with ids T0001..T0012 at both, merged
// into one input with a `site` column: a record of the 8-sensor site leaves if_9..if_16 empty.
struct TwoSiteStream {
  test::TempDir dir;
  std::string manifest = dir.file("m.json");
  std::vector<std::string> lines;  // the merged input's records, without the header
  std::string header;
  TwoSiteStream() {
    REQUIRE(run_ssrfleet("simulate --road AS1 --trucks 12 --seed 3 --quiet --out " + q(dir.file("a.csv")), dir).status == 0);
    REQUIRE(run_ssrfleet("simulate --road AS2 --sensors 70,2,8 --trucks 12 --seed 4 --quiet --out " + q(dir.file("b.csv")), dir)
                .status == 0);
    test::write_text(manifest, R"({"sites": [
        {"name": "north", "road": "AS1", "sensors": "76,1.5,16"},
        {"name": "south", "road": "AS2", "sensors": "70,2,8"}]})");
    header = "truck_id,site,speed_mps,sprung_mass_kg";
    for (int m = 1; m <= 16; ++m) header += std::string(",if_") + std::to_string(m);
    const auto a = records_of(dir.file("a.csv"), "north", 16), b = records_of(dir.file("b.csv"), "south", 16);
    for (std::size_t i = 0; i < a.size(); ++i) {
      lines.push_back(a[i]);
      lines.push_back(b[i]);
    }
  }
  // A simulated log's records as lines of the merged input.
  static std::vector<std::string> records_of(const std::string& path, const std::string& site, int columns) {
    std::istringstream in(test::read_text(path));
    io::CsvReader csv(in, path);
    io::CsvRow row;
    REQUIRE(csv.next(row));
    const auto h = row.fields;
    const auto col = [&](const std::string& name) { return static_cast<std::size_t>(io::column_index(h, name)); };
    std::vector<std::string> out;
    while (csv.next(row)) {
      std::string line = row.fields[col("truck_id")] + "," + site + "," + row.fields[col("speed_mps")] + "," +
                         row.fields[col("sprung_mass_kg")];
      for (int m = 1; m <= columns; ++m) {
        const long c = io::column_index(h, std::string("if_") + std::to_string(m));
        line += ',';
        if (c >= 0) line += row.fields[static_cast<std::size_t>(c)];
      }
      out.push_back(line);
    }
    return out;
  }
  std::string input(const std::vector<std::string>& records, const std::string& name) const {
    std::string text = header + "\n";
    for (const auto& r : records) text += r + "\n";
    const std::string path = dir.file(name);
    test::write_text(path, text);
    return path;
  }
  test::RunResult stream(const std::string& state, const std::string& input_path, const std::string& more = "") const {
    return run_ssrfleet("stream --sites " + q(manifest) + " --state " + q(state) + " --input " + q(input_path) +
                            " --particles 64 --threads 1 --seed 5 --quiet " + more,
                        dir);
  }
};
}  // namespace

TEST_CASE("stream --sites absorbs every site's records into one fleet and quarantines a record of no or an unknown "
          "site",
          "[cli][stream][sites]") {
  TwoSiteStream s;
  std::vector<std::string> records = s.lines;
  const std::string ones8 = ",1,1,1,1,1,1,1,1", empty8 = ",,,,,,,,";
  records.push_back("X1,west,23,4000" + ones8 + ones8);   // a site the manifest does not have
  records.push_back("X2,,23,4000" + ones8 + ones8);       // no site
  records.push_back("X3,south,23,4000" + ones8 + ones8);  // an 8-sensor site's record with 16 values
  records.push_back("T0001,south,23,4000" + ones8 + empty8);  // T0001 of south again
  const std::string input = s.input(records, "in.csv");
  const std::string state = s.dir.file("state");
  const auto r = s.stream(state, input);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("24 trucks absorbed, 4 rejected") != std::string::npos);
  const std::string rejects = test::read_text(state + "/rejects.csv");
  CHECK(rejects.find("# line 26: site: site 'west' is not one of the manifest's sites (north, south)") != std::string::npos);
  CHECK(rejects.find("# line 27: site: empty") != std::string::npos);
  CHECK(rejects.find("# line 28: if_9: site 'south' has 8 sensors") != std::string::npos);
  CHECK(rejects.find("# line 29: truck_id: duplicate truck_id 'south:T0001'") != std::string::npos);
  for (int line = 26; line <= 29; ++line) CHECK(rejects.find(records[static_cast<std::size_t>(line - 2)] + "\n") != std::string::npos);

  // One fleet: T0001..T0012 at both sites are 24 trucks; each site has its 12.
  const auto cloud = io::read_posterior_file(state);
  CHECK(cloud.trucks_seen == 24);
  REQUIRE(cloud.sites.size() == 2);
  CHECK(cloud.sites[0].name == "north");
  CHECK(cloud.sites[0].trucks_seen == 12);
  CHECK(cloud.sites[1].name == "south");
  CHECK(cloud.sites[1].sensors == 8);
  CHECK(cloud.sites[1].trucks_seen == 12);
  // Each site predicted from the state, with its own sensors.
  const auto p = run_ssrfleet("predict --posterior " + q(state) + " --sites " + q(s.manifest) +
                                  " --site south --draws 10 --trucks-per-draw 10 --quiet",
                              s.dir);
  INFO(p.err);
  REQUIRE(p.status == 0);
  CHECK(std::count(p.out.begin(), p.out.end(), '\n') == 9);

  // An input without a site column, or options that a stream of several sites cannot take.
  test::write_text(s.dir.file("plain.csv"), test::read_text(s.dir.file("a.csv")));
  const auto no_column = s.stream(s.dir.file("state2"), s.dir.file("plain.csv"));
  CHECK(no_column.status == 65);
  CHECK(no_column.err.find("field 'site'") != std::string::npos);
  for (const char* bad : {"--road AS2", "--window 5", "--model tyre_damping"}) {
    const auto u = s.stream(s.dir.file("state3"), input, bad);
    INFO(bad << ": " << u.err);
    CHECK(u.status == 64);
  }
}

TEST_CASE("a stream of several sites resumes to the very posterior, and refuses to resume with other sites",
          "[cli][stream][sites]") {
  TwoSiteStream s;
  const std::string all = s.input(s.lines, "all.csv");
  const std::string first = s.input({s.lines.begin(), s.lines.begin() + 9}, "first.csv");
  REQUIRE(s.stream(s.dir.file("straight"), all).status == 0);
  const std::string state = s.dir.file("resumed");
  REQUIRE(s.stream(state, first).status == 0);
  const auto again = s.stream(state, all);
  INFO(again.err);
  REQUIRE(again.status == 0);
  CHECK(again.err.find("15 trucks absorbed, 0 rejected") != std::string::npos);
  CHECK(again.err.find("9 skipped as already absorbed; 24 trucks in the posterior") != std::string::npos);
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(s.dir.file("straight") + "/posterior.json"));

  // The same roads under other names (or another order) are other sites: refused by name.
  test::write_text(s.manifest, R"({"sites": [
      {"name": "south", "road": "AS2", "sensors": "70,2,8"},
      {"name": "north", "road": "AS1", "sensors": "76,1.5,16"}]})");
  const auto other = s.stream(state, all);
  CHECK(other.status == 65);
  CHECK(other.err.find(state + "/checkpoint.bin") != std::string::npos);
  CHECK(other.err.find("sites north, south") != std::string::npos);
  // A stream of one site on it: refused too.
  const auto one = run_ssrfleet("stream --state " + q(state) + " --input " + q(all) + " --particles 64 --seed 5 --quiet", s.dir);
  CHECK(one.status == 65);
  CHECK(one.err.find("one site (no manifest)") != std::string::npos);
}

TEST_CASE("a stream state of one site written before states named their sites (format 4) resumes exactly",
          "[cli][stream][sites]") {
  test::TempDir dir;
  REQUIRE(run_ssrfleet("simulate --road AS1 --trucks 8 --seed 9 --quiet --out " + q(dir.file("log.csv")), dir).status == 0);
  const std::string log = test::read_text(dir.file("log.csv"));
  // The first 4 records (the header and comment lines, then 4 trucks).
  std::string head;
  {
    std::istringstream in(log);
    std::string line;
    int records = 0;
    bool header = false;
    while (std::getline(in, line) && records < 4) {
      head += line + "\n";
      if (!line.empty() && line[0] != '#') (header ? ++records : (header = true, 0));
    }
  }
  test::write_text(dir.file("head.csv"), head);
  const auto stream = [&](const std::string& state, const std::string& input) {
    return run_ssrfleet("stream --state " + q(state) + " --input " + q(input) + " --particles 64 --threads 1 --seed 2 --quiet",
                        dir);
  };
  REQUIRE(stream(dir.file("straight"), dir.file("log.csv")).status == 0);
  const std::string state = dir.file("old");
  REQUIRE(stream(state, dir.file("head.csv")).status == 0);

  // Format 4 is format 5 without the site list (a count of 1 and one empty name: 16 bytes) after
  // the model's name, with the version changed and the whole file sealed again.
  std::string bytes = test::read_text(state + "/checkpoint.bin");
  std::size_t at = 8 + 4;
  for (int text = 0; text < 2; ++text) {  // source, model
    std::uint64_t n = 0;
    std::memcpy(&n, bytes.data() + at, 8);
    at += 8 + n;
  }
  std::uint64_t count = 0, empty_name = 1;
  std::memcpy(&count, bytes.data() + at, 8);
  std::memcpy(&empty_name, bytes.data() + at + 8, 8);
  REQUIRE(count == 1);
  REQUIRE(empty_name == 0);
  bytes.erase(at, 16);
  const std::uint32_t v4 = 4;
  std::memcpy(bytes.data() + 8, &v4, 4);
  const std::size_t body = bytes.size() - 8;
  const std::uint64_t seal = detail::fnv1a(detail::kFnvOffset, bytes.data(), body);
  std::memcpy(bytes.data() + body, &seal, 8);
  test::write_text(state + "/checkpoint.bin", bytes);
  // The history's last report names the checkpoint by its seal: name the edited one (its row set
  // taken out with the sqlite3 shell and written again through HistoryDb, which seals the row).
  const std::string history = state + "/history.sqlite";
  records::HistoryReport last;
  {
    const io::HistoryDb db(history, "base");
    REQUIRE(db.last_seq() == std::optional<std::uint64_t>(4));
    last = db.read_report(4);
  }
  last.checkpoint_checksum = seal;
  REQUIRE(std::system(("sqlite3 " + q(history) + " 'DELETE FROM predictions WHERE seq = 4; DELETE FROM hyperparameters "
                       "WHERE seq = 4; DELETE FROM reports WHERE seq = 4;'").c_str()) == 0);
  io::HistoryDb(history, "base").append(last);

  const auto resumed = stream(state, dir.file("log.csv"));
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(test::read_text(state + "/posterior.json") == test::read_text(dir.file("straight") + "/posterior.json"));
}
