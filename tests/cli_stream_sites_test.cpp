// A stream of several sites, one fleet: `stream --sites M` reads one input
// whose `site` column names each record's site, quarantines a record of no or an unknown site, keeps
// truck ids per site, resumes exactly, refuses a resume with other sites, and reads a state of one
// site written before states named their sites.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/joint_sites.hpp"
#include "io/csv_reader.hpp"
#include "io/history_db.hpp"
#include "io/posterior_json.hpp"
#include "model/truck_table.hpp"
#include "gained_log.hpp"
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
  for (const char* bad : {"--road AS2", "--model tyre_damping"}) {
    const auto u = s.stream(s.dir.file("state3"), input, bad);
    INFO(bad << ": " << u.err);
    CHECK(u.status == 64);
  }
}

TEST_CASE("a stream of several sites resumes to the very posterior, and refuses to resume with other sites",
          "[cli][stream][sites][heavy]") {
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

TEST_CASE("a stream of a one-site manifest reads the site column too, and quarantines a record of another site",
          "[cli][stream][sites]") {
  TwoSiteStream s;
  test::write_text(s.manifest, R"({"sites": [{"name": "north", "road": "AS1", "sensors": "76,1.5,16"}]})");
  // north's and south's records: south's are another site's, not north's trucks.
  const auto r = s.stream(s.dir.file("state"), s.input(s.lines, "in.csv"));
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("12 trucks absorbed, 12 rejected") != std::string::npos);
  CHECK(test::read_text(s.dir.file("state") + "/rejects.csv").find("site 'south' is not one of the manifest's sites (north)") !=
        std::string::npos);
  CHECK(io::read_posterior_file(s.dir.file("state")).trucks_seen == 12);
}

namespace {
// The end of the sealed record that starts at `begin` (binary_io.hpp: a running FNV-1a 64 of the
// record's bytes, then that hash): the first offset where the next 8 bytes are the hash so far.
std::size_t sealed_record_end(const std::string& bytes, std::size_t begin) {
  std::uint64_t h = detail::kFnvOffset;
  for (std::size_t at = begin; at + 8 <= bytes.size(); ++at) {
    std::uint64_t stored = 0;
    std::memcpy(&stored, bytes.data() + at, 8);
    if (at > begin && stored == h) return at;
    h = detail::fnv1a(h, bytes.data() + at, 1);
  }
  FAIL("no seal after offset " << begin);
  return 0;
}
void seal_again(std::string& bytes, std::size_t begin, std::size_t seal_at) {
  const std::uint64_t h = detail::fnv1a(detail::kFnvOffset, bytes.data() + begin, seal_at - begin);
  std::memcpy(bytes.data() + seal_at, &h, 8);
}

// A stream state of this build's format with 4 of a log's 8 trucks, a straight run over all 8, and
// the edits that turn the state into one of an older format.
struct OlderState {
  test::TempDir dir;
  std::string log = dir.file("log.csv"), state = dir.file("old"), straight = dir.file("straight");
  OlderState() {
    REQUIRE(run_ssrfleet("simulate --road AS1 --trucks 8 --seed 9 --quiet --out " + q(log), dir).status == 0);
    std::string head;  // the comments, the header and 4 trucks
    std::istringstream in(test::read_text(log));
    std::string line;
    int lines = 0;
    while (std::getline(in, line)) {
      if (!line.empty() && line[0] != '#' && ++lines > 5) break;
      head += line + "\n";
    }
    test::write_text(dir.file("head.csv"), head);
    REQUIRE(stream(straight, log).status == 0);
    REQUIRE(stream(state, dir.file("head.csv")).status == 0);
  }
  test::RunResult stream(const std::string& state_dir, const std::string& input) const {
    return run_ssrfleet("stream --state " + q(state_dir) + " --input " + q(input) +
                            " --particles 64 --threads 1 --seed 2 --quiet",
                        dir);
  }
  // checkpoint.bin as stream format 4: format 5 without the site list after the model's name (a
  // count of 1 and one empty name: 16 bytes) and with the version changed. Returns where the list
  // was; the caller seals the file again.
  static std::size_t drop_site_list(std::string& bytes) {
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
    return at;
  }
  // Seals the edited checkpoint, writes it, and names it in the history's last report (report 4:
  // its row set taken out with the sqlite3 shell and written again through HistoryDb, which seals
  // the row), as the history of a state of that format would.
  void write_checkpoint(std::string& bytes) const {
    seal_again(bytes, 0, bytes.size() - 8);
    test::write_text(state + "/checkpoint.bin", bytes);
    const std::string history = state + "/history.sqlite";
    records::HistoryReport last;
    {
      const io::HistoryDb db(history, "base");
      REQUIRE(db.last_seq() == std::optional<std::uint64_t>(4));
      last = db.read_report(4);
    }
    std::memcpy(&last.checkpoint_checksum, bytes.data() + bytes.size() - 8, 8);
    REQUIRE(std::system(("sqlite3 " + q(history) + " 'DELETE FROM predictions WHERE seq = 4; DELETE FROM hyperparameters "
                         "WHERE seq = 4; DELETE FROM reports WHERE seq = 4;'").c_str()) == 0);
    io::HistoryDb(history, "base").append(last);
  }
  std::string straight_posterior() const { return test::read_text(straight + "/posterior.json"); }
};
}  // namespace

TEST_CASE("a stream state of one site written before states named their sites (format 4) resumes exactly",
          "[cli][stream][sites]") {
  const OlderState c;
  std::string bytes = test::read_text(c.state + "/checkpoint.bin");
  OlderState::drop_site_list(bytes);
  c.write_checkpoint(bytes);
  const auto resumed = c.stream(c.state, c.log);
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(test::read_text(c.state + "/posterior.json") == c.straight_posterior());
}

TEST_CASE("a stream state written before sites (stream format 4, truck records without a site) resumes as its "
          "tables were built, its truck log written anew",
          "[cli][stream][sites]") {
  const OlderState c;
  // What the resumed state must give: an old table has no z-moment slopes and is read with slopes
  // of 0 (evaluated as the build that wrote it evaluated it), so the reference is this build's state
  // of the same 4 trucks with every table's slopes set to 0, resumed on the whole log.
  const std::string zeroed = c.dir.file("zeroed");
  std::filesystem::copy(c.state, zeroed, std::filesystem::copy_options::recursive);
  {
    std::string log = test::read_text(zeroed + "/trucks.bin");
    std::size_t at = sealed_record_end(log, 0) + 8;
    while (at < log.size()) {
      std::uint64_t id_length = 0;
      std::memcpy(&id_length, log.data() + at, 8);
      const std::size_t nodes_at = at + 8 + id_length + 4 + 8 + 8 + (16 + 16 * 8) + sizeof(model::TruckFit);
      std::uint32_t nodes = 0;
      std::memcpy(&nodes, log.data() + nodes_at, 4);
      const std::size_t end = sealed_record_end(log, at);
      const std::size_t slopes = 2 * sizeof(float) * nodes;
      REQUIRE(log.substr(end - slopes, slopes) != std::string(slopes, '\0'));
      std::memset(log.data() + end - slopes, 0, slopes);
      seal_again(log, at, end);
      at = end + 8;
    }
    test::write_text(zeroed + "/trucks.bin", log);
  }
  REQUIRE(c.stream(zeroed, c.log).status == 0);
  const std::string expected = test::read_text(zeroed + "/posterior.json");
  CHECK(expected != c.straight_posterior());  // the slopes matter: the checks below can fail
  // The truck log: a sealed header (magic, generation), then per truck a sealed record that starts
  // with its id (a length and the bytes) and, from marginal target format 3 on, the site's index;
  // from format 5 on the table ends with two slope arrays (a float per entry each). After the site:
  // speed, mass, the 16 impact factors (two 8-byte sizes and the values), the fit, the entry count.
  std::string log = test::read_text(c.state + "/trucks.bin");
  std::size_t at = sealed_record_end(log, 0) + 8;
  int records = 0;
  std::size_t slope_bytes_removed = 0;
  while (at < log.size()) {
    std::uint64_t id_length = 0;
    std::memcpy(&id_length, log.data() + at, 8);
    const std::size_t site_at = at + 8 + id_length;
    REQUIRE(log.substr(site_at, 4) == std::string(4, '\0'));
    const std::size_t nodes_at = site_at + 4 + 8 + 8 + (16 + 16 * 8) + sizeof(model::TruckFit);
    std::uint32_t nodes = 0;
    std::memcpy(&nodes, log.data() + nodes_at, 4);
    REQUIRE(nodes > 0);
    const std::size_t end = sealed_record_end(log, at);
    const std::size_t slopes = 2 * sizeof(float) * nodes;
    log.erase(end - slopes, slopes);
    log.erase(site_at, 4);
    seal_again(log, at, end - slopes - 4);
    at = end - slopes - 4 + 8;
    slope_bytes_removed += slopes;
    ++records;
  }
  REQUIRE(records == 4);
  test::write_text(c.state + "/trucks.bin", log);

  // The checkpoint: stream format 4 (no site list after the model), marginal target format 2.
  std::string bytes = test::read_text(c.state + "/checkpoint.bin");
  const std::size_t pos = OlderState::drop_site_list(bytes);
  // Then seq, lines consumed, rejects' bytes, the split flag, the fixed classes (none), the classes
  // (one, unlabelled: an empty label), its trucks written and its truck log's length, 16 bytes less.
  const std::size_t log_bytes_at = pos + 8 + 8 + 8 + 1 + 8 + 8 + 8 + 8;
  std::uint64_t log_bytes = 0;
  std::memcpy(&log_bytes, bytes.data() + log_bytes_at, 8);
  REQUIRE(log_bytes == log.size() + 4 * 4 + slope_bytes_removed);
  log_bytes = log.size();
  std::memcpy(bytes.data() + log_bytes_at, &log_bytes, 8);
  const std::uint32_t v2 = 2;
  const std::uint64_t target_magic = 0x4e52414d46525353ULL;  // "SSRFMARN"
  const std::size_t target = bytes.find(std::string(reinterpret_cast<const char*>(&target_magic), 8));
  REQUIRE(target != std::string::npos);
  std::memcpy(bytes.data() + target + 8, &v2, 4);
  // Marginal target format 4 added the model (an empty name: its 8-byte length 0) and ψ (a 0 x 64
  // matrix: two 8-byte sizes) just before the truck count (4).
  std::string model_and_count(16, '\0');
  for (const std::int64_t v : {std::int64_t{64}, std::int64_t{4}})
    model_and_count.append(reinterpret_cast<const char*>(&v), sizeof v);
  const std::size_t model_at = bytes.find(model_and_count, target);
  REQUIRE(model_at != std::string::npos);
  bytes.erase(model_at, 24);
  // Marginal target format 6 added, after the truck count, whether a ψ window follows (0: none).
  REQUIRE(bytes[model_at + 8] == '\0');
  bytes.erase(model_at + 8, 1);
  c.write_checkpoint(bytes);

  const auto resumed = c.stream(c.state, c.log);
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(resumed.err.find("4 trucks absorbed") != std::string::npos);
  CHECK(test::read_text(c.state + "/posterior.json") == expected);
  // The log was written anew in this build's records, under a generation of its own.
  const std::string rewritten = test::read_text(c.state + "/trucks.bin");
  std::int32_t generation = 0;
  std::memcpy(&generation, rewritten.data() + 8, 4);
  CHECK(generation >= (1 << 24));
  CHECK(rewritten.size() == test::read_text(c.straight + "/trucks.bin").size());
  // And it resumes again, as any state of this build.
  const auto again = c.stream(c.state, c.log);
  INFO(again.err);
  REQUIRE(again.status == 0);
  CHECK(again.err.find("0 trucks absorbed, 0 rejected") != std::string::npos);
  CHECK(test::read_text(c.state + "/posterior.json") == expected);
}

TEST_CASE("a stream divides a site's known calibration out of its records, and refuses to resume with another",
          "[cli][stream][sites][calibration][heavy]") {
  TwoSiteStream s;
  const std::string straight = s.dir.file("clean");
  REQUIRE(s.stream(straight, s.input(s.lines, "clean.csv")).status == 0);
  // North's sensor 3 read double and its sensor 7 half (exact in binary: the corrected records are
  // the clean ones' bits), as the manifest's calibration says.
  std::vector<double> north(16, 1.0);
  north[2] = 2.0;
  north[6] = 0.5;
  test::write_gained_log(s.dir.file("a.csv"), s.dir.file("a-gained.csv"), north);
  const auto gained = TwoSiteStream::records_of(s.dir.file("a-gained.csv"), "north", 16);
  std::vector<std::string> lines = s.lines;
  for (std::size_t i = 0; i < gained.size(); ++i) lines[2 * i] = gained[i];  // north's records come first in each pair
  const auto manifest_with = [&](const std::string& calibration) {
    test::write_text(s.manifest, R"({"sites": [
        {"name": "north", "road": "AS1", "sensors": "76,1.5,16", "calibration": )" + calibration + R"(},
        {"name": "south", "road": "AS2", "sensors": "70,2,8"}]})");
  };
  manifest_with("[1,1,2,1,1,1,0.5,1,1,1,1,1,1,1,1,1]");
  const std::string state = s.dir.file("calibrated");
  const std::string input = s.input(lines, "gained.csv");
  const auto r = s.stream(state, input);
  INFO(r.err);
  REQUIRE(r.status == 0);
  const auto a = io::read_posterior_file(straight), b = io::read_posterior_file(state);
  CHECK(a.theta == b.theta);
  CHECK((a.weights == b.weights).all());
  CHECK(a.calibration.empty());
  REQUIRE(b.calibration.size() == 2);
  CHECK(b.calibration[0].gain[2] == 2.0);
  CHECK(b.calibration[0].gain[6] == 0.5);
  // Another calibration is another site: the absorbed trucks were corrected with these gains.
  manifest_with("[1,1,2,1,1,1,0.6,1,1,1,1,1,1,1,1,1]");
  const auto other = s.stream(state, input);
  CHECK(other.status == 65);
  CHECK(other.err.find("north (calibration 1,1,2,1,1,1,0.5,") != std::string::npos);
  CHECK(other.err.find("north (calibration 1,1,2,1,1,1,0.59999999999999998,") != std::string::npos);
  // The same calibration resumes.
  manifest_with("[1,1,2,1,1,1,0.5,1,1,1,1,1,1,1,1,1]");
  const auto again = s.stream(state, input);
  INFO(again.err);
  CHECK(again.status == 0);
}
