#include <sstream>

#include <catch2/catch.hpp>

#include "io/csv_reader.hpp"
#include "io/wim_log.hpp"
#include "test_support.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {
const char* kHeader = "truck_id,time_s,speed_mps,sprung_mass_kg,if_1,if_2,if_3\n";

struct ReadAll {
  std::vector<records::WimRecord> records;
  std::vector<io::Rejection> rejections;
};

ReadAll read_all(const std::string& text) {
  std::istringstream in(text);
  io::WimLogReader reader(in, "log.csv", 420.0);
  ReadAll all;
  records::WimRecord r;
  io::Rejection why;
  for (;;) {
    const auto s = reader.next(r, why);
    if (s == io::WimLogReader::Status::end) break;
    if (s == io::WimLogReader::Status::record) all.records.push_back(r);
    else all.rejections.push_back(why);
  }
  return all;
}
}  // namespace

TEST_CASE("CSV lines split into trimmed fields and comments are skipped", "[io]") {
  const auto f = io::split_csv_line(" a , \"b\",,c\r");
  REQUIRE(f.size() == 4);
  CHECK(f[0] == "a");
  CHECK(f[1] == "b");
  CHECK(f[2].empty());
  CHECK(f[3] == "c");
  std::istringstream in("# comment\n\n  # indented comment\nx,y\n");
  io::CsvReader csv(in, "t");
  io::CsvRow row;
  REQUIRE(csv.next(row));
  CHECK(row.line == 4);
  CHECK(row.fields == std::vector<std::string>{"x", "y"});
  CHECK_FALSE(csv.next(row));
}

TEST_CASE("numbers must be whole finite fields", "[io]") {
  CHECK(io::parse_finite("1.5e3", "f", 1, "x") == 1500.0);
  CHECK_THROWS_AS(io::parse_finite("", "f", 1, "x"), DataError);
  CHECK_THROWS_AS(io::parse_finite("12abc", "f", 1, "x"), DataError);
  CHECK_THROWS_AS(io::parse_finite("nan", "f", 1, "x"), DataError);
  CHECK_THROWS_AS(io::parse_finite("inf", "f", 1, "x"), DataError);
  CHECK_THROWS_AS(io::parse_finite("1e999", "f", 1, "x"), DataError);
  try {
    io::parse_finite("abc", "data.csv", 7, "speed_mps");
    FAIL("no exception");
  } catch (const DataError& e) {
    CHECK(std::string(e.what()) == "data.csv:7: field 'speed_mps': 'abc' is not a number");
  }
}

TEST_CASE("a WIM log round-trips bit-exactly through write and read", "[io]") {
  std::vector<records::WimRecord> records(2);
  records[0].truck_id = "A";
  records[0].speed_mps = 23.43000000000001;
  records[0].sprung_mass_kg = 4450.123456789;
  records[0].impact_factor.resize(3);
  records[0].impact_factor << 1.0 / 3.0, 0.98765432101234567, 1.2;
  records[1] = records[0];
  records[1].truck_id = "B";
  records[1].impact_factor[1] = 1.0 + 1e-16;
  std::ostringstream os;
  io::write_wim_log(os, records);
  const auto back = read_all(os.str());
  REQUIRE(back.rejections.empty());
  REQUIRE(back.records.size() == 2);
  for (int i = 0; i < 2; ++i) {
    CHECK(back.records[i].truck_id == records[i].truck_id);
    CHECK(back.records[i].speed_mps == records[i].speed_mps);
    CHECK(back.records[i].sprung_mass_kg == records[i].sprung_mass_kg);
    CHECK(back.records[i].impact_factor == records[i].impact_factor);
  }
}

TEST_CASE("tyre forces are converted to impact factors with the site's unsprung mass", "[io]") {
  const double w = (420.0 + 4000.0) * 9.81;
  std::ostringstream text;
  text.precision(17);
  text << "truck_id,speed_mps,sprung_mass_kg,force_1,force_2,extra\nT1,20,4000," << w << "," << 1.1 * w << ",zzz\n";
  const auto all = read_all(text.str());
  REQUIRE(all.records.size() == 1);
  CHECK(all.records[0].impact_factor[0] == Approx(1.0).epsilon(1e-15));
  CHECK(all.records[0].impact_factor[1] == Approx(1.1).epsilon(1e-15));
  CHECK_FALSE(all.records[0].time_s.has_value());
}

TEST_CASE("a header missing a required column names the column", "[io]") {
  for (const std::string missing : {"truck_id", "speed_mps", "sprung_mass_kg", "if_1"}) {
    std::string header = "truck_id,speed_mps,sprung_mass_kg,if_1,if_2";
    const auto pos = header.find(missing);
    header.erase(pos, missing.size() + (pos + missing.size() < header.size() ? 1 : 0));
    if (header.back() == ',') header.pop_back();
    if (missing == "if_1") header = "truck_id,speed_mps,sprung_mass_kg,if_2";
    std::istringstream in(header + "\nT1,20,4000,1.0\n");
    try {
      io::WimLogReader reader(in, "log.csv", 420.0);
      FAIL("accepted a header without " << missing);
    } catch (const DataError& e) {
      CHECK(e.file() == "log.csv");
      CHECK(e.line() == 1);
      CHECK(e.field() == missing);
    }
  }
}

TEST_CASE("every kind of bad WIM record is rejected with its line and field while good ones pass", "[io]") {
  const std::string text = std::string(kHeader) +
                           "G1,0,20,4000,1.0,1.01,0.99\n"        // line 2 good
                           "B1,1,20,4000,1.0,1.01\n"             // 3 ragged
                           "B2,2,abc,4000,1.0,1.0,1.0\n"         // 4 non-numeric speed
                           "B3,3,20,nan,1.0,1.0,1.0\n"           // 5 NaN mass
                           "B4,4,-3,4000,1.0,1.0,1.0\n"          // 6 negative speed
                           "B5,5,20,4000000,1.0,1.0,1.0\n"       // 7 absurd mass
                           "G1,6,20,4000,1.0,1.0,1.0\n"          // 8 duplicate id
                           "B6,7,20,4000,1.0,7.5,1.0\n"          // 9 impossible IF
                           "B7,8,20,4000,1.0,-0.2,1.0\n"         // 10 negative IF
                           ",9,20,4000,1.0,1.0,1.0\n"            // 11 empty id
                           "B8,x,20,4000,1.0,1.0,1.0\n"          // 12 bad time
                           "G2,10,25,5000,0.9,1.1,1.0\n";        // 13 good
  const auto all = read_all(text);
  REQUIRE(all.records.size() == 2);
  CHECK(all.records[0].truck_id == "G1");
  CHECK(all.records[1].truck_id == "G2");
  CHECK(all.records[1].line == 13);
  REQUIRE(all.rejections.size() == 10);
  const std::vector<std::pair<std::size_t, std::string>> expected = {
      {3, "columns"}, {4, "speed_mps"}, {5, "sprung_mass_kg"}, {6, "speed_mps"}, {7, "sprung_mass_kg"},
      {8, "truck_id"}, {9, "if_2"}, {10, "if_2"}, {11, "truck_id"}, {12, "time_s"}};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    CHECK(all.rejections[i].line == expected[i].first);
    CHECK(all.rejections[i].field == expected[i].second);
    CHECK(all.rejections[i].message.find("log.csv:" + std::to_string(expected[i].first) + ":") == 0);
    CHECK(text.find(all.rejections[i].raw + "\n") != std::string::npos);
  }
}

TEST_CASE("reading a whole log stops at the first bad record naming file line and field", "[io]") {
  test::TempDir dir;
  const std::string path = dir.file("log.csv");
  test::write_text(path, std::string(kHeader) + "G1,0,20,4000,1,1,1\nB1,1,20,4000,1,oops,1\n");
  try {
    io::read_wim_log_file(path, 420.0);
    FAIL("accepted a bad log");
  } catch (const DataError& e) {
    CHECK(e.file() == path);
    CHECK(e.line() == 3);
    CHECK(e.field() == "if_2");
  }
  CHECK_THROWS_AS(io::read_wim_log_file(dir.file("missing.csv"), 420.0), MissingInputError);
}
