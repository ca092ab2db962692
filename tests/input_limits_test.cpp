// Absurd inputs fail fast: a 1 GB line, a million columns, a billion trucks or
// particles, a surface of 1e12 points are each a clear error (file, line, field) within a second,
// never an out-of-memory kill. The limits are in util/line_reader.hpp and docs/site-data.md.
#include <algorithm>
#include <chrono>
#include <sstream>
#include <streambuf>
#include <string>

#include <catch2/catch.hpp>

#include "io/csv_reader.hpp"
#include "io/force_log.hpp"
#include "io/truck_list_csv.hpp"
#include "io/wim_log.hpp"
#include "road/crg_reader.hpp"
#include "road/surface_csv.hpp"
#include "test_support.hpp"
#include "util/line_reader.hpp"

using namespace ssrfleet;
using test::data_error;

namespace {

// A stream of `prefix` followed by `total` bytes of `fill` and no newline, made up as it is read
// (nothing is stored but one 64 KiB buffer), counting what the reader took from it.
class GeneratedStream : public std::streambuf {
 public:
  GeneratedStream(std::string prefix, std::size_t total, char fill)
      : prefix_(std::move(prefix)), left_(total), block_(std::size_t{1} << 16, fill) {
    setg(prefix_.data(), prefix_.data(), prefix_.data() + prefix_.size());
  }
  std::size_t served() const { return served_ + static_cast<std::size_t>(gptr() - eback()); }

 protected:
  int_type underflow() override {
    served_ += static_cast<std::size_t>(gptr() - eback());
    if (left_ == 0) return traits_type::eof();
    const std::size_t n = std::min(left_, block_.size());
    left_ -= n;
    setg(block_.data(), block_.data(), block_.data() + n);
    return traits_type::to_int_type(block_[0]);
  }

 private:
  std::string prefix_;
  std::size_t left_;
  std::string block_;
  std::size_t served_ = 0;
};

constexpr std::size_t kGiB = std::size_t{1} << 30;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

TEST_CASE("a 1 GB line is refused within a second, having read no more than the 1 MiB limit", "[io][limits]") {
  SECTION("the line reader stops at its limit") {
    GeneratedStream source("", kGiB, 'x');
    std::istream in(&source);
    std::string line;
    CHECK(read_bounded_line(in, line, 100) == LineRead::too_long);
    CHECK(line.size() == 100);
    CHECK(source.served() == 100);  // the character after the limit is left unread
  }
  SECTION("a WIM log whose second line is 1 GB of digits") {
    GeneratedStream source("truck_id,speed_mps,sprung_mass_kg,if_1\n", kGiB, '7');
    std::istream in(&source);
    const auto start = std::chrono::steady_clock::now();
    io::WimLogReader reader(in, "huge.csv", 420.0);
    records::WimRecord record;
    io::Rejection why;
    const auto e = data_error([&] { reader.next(record, why); });
    const double took = seconds_since(start);
    REQUIRE(e);
    CHECK(e->file() == "huge.csv");
    CHECK(e->line() == 2);
    CHECK(e->field() == "line");
    CHECK_THAT(e->what(), Catch::Contains("longer than 1048576 bytes"));
    CHECK(took < 1.0);
    CHECK(source.served() < 2 * kMaxCsvLineBytes);
  }
  SECTION("a header line of 1 GB (a binary file given as a log)") {
    GeneratedStream source("", kGiB, 'a');
    std::istream in(&source);
    const auto start = std::chrono::steady_clock::now();
    const auto e = data_error([&] { io::read_force_log(in, "binary.csv", 0); });
    REQUIRE(e);
    CHECK(e->line() == 1);
    CHECK(e->field() == "line");
    CHECK(seconds_since(start) < 1.0);
    CHECK(source.served() < 2 * kMaxCsvLineBytes);
  }
  SECTION("a road CSV row of 1 GB") {
    GeneratedStream source("x_m,0,1\n0,0,0\n", kGiB, '0');
    std::istream in(&source);
    const auto start = std::chrono::steady_clock::now();
    const auto e = data_error([&] { road::read_surface_csv(in, "road.csv"); });
    REQUIRE(e);
    CHECK(e->file() == "road.csv");
    CHECK(e->line() == 3);
    CHECK(e->field() == "line");
    CHECK(seconds_since(start) < 1.0);
    CHECK(source.served() < 2 * kMaxCsvLineBytes);
  }
}

TEST_CASE("a header of a million columns is refused at its line, naming the limit", "[io][limits]") {
  const std::string header = "truck_id,speed_mps,sprung_mass_kg" + std::string(1'000'000, ',') + "\n";
  const auto start = std::chrono::steady_clock::now();
  std::istringstream wim(header);
  auto e = data_error([&] { io::WimLogReader(wim, "wide.csv", 420.0); });
  REQUIRE(e);
  CHECK(e->line() == 1);
  CHECK(e->field() == "columns");
  CHECK_THAT(e->what(), Catch::Contains("1000003 fields") && Catch::Contains("100000"));
  std::istringstream trucks("# a comment first\n" + header);
  e = data_error([&] { io::read_truck_list(trucks, "wide.csv", 0.0, 5.0); });
  REQUIRE(e);
  CHECK(e->line() == 2);
  CHECK(e->field() == "columns");
  std::istringstream road("x_m" + std::string(1'000'000, ',') + "\n");
  e = data_error([&] { road::read_surface_csv(road, "wide.csv"); });
  REQUIRE(e);
  CHECK(e->field() == "columns");
  CHECK(seconds_since(start) < 1.0);
}

TEST_CASE("a header of 99,999 numbered sensor columns is read in linear time", "[io][limits]") {
  // Finding if_1..if_M one name at a time was M x columns string comparisons: 1e10 here.
  std::string header = "truck_id,speed_mps,sprung_mass_kg";
  std::string row = "A,23,4450";
  for (int m = 1; m <= 99'996; ++m) {
    header += ",if_" + std::to_string(m);
    row += ",1";
  }
  std::istringstream in(header + "\n" + row + "\n");
  const auto start = std::chrono::steady_clock::now();
  io::WimLogReader reader(in, "many.csv", 420.0);
  records::WimRecord record;
  io::Rejection why;
  REQUIRE(reader.next(record, why) == io::WimLogReader::Status::record);
  CHECK(reader.sensors() == 99'996);
  CHECK(seconds_since(start) < 1.0);
}

TEST_CASE("an OpenCRG header declaring 1e12 points is refused within a second", "[road][limits]") {
  const std::string text =
      "$ROAD_CRG\nREFERENCE_LINE_START_U = 0\nREFERENCE_LINE_END_U = 1e12\nREFERENCE_LINE_INCREMENT = 1\n"
      "LONG_SECTION_V_RIGHT = -0.5\nLONG_SECTION_V_LEFT = 0.5\nLONG_SECTION_V_INCREMENT = 0.5\n$\n"
      "$KD_DEFINITION\n#:KRBI\nD:long section 1,m\nD:long section 2,m\nD:long section 3,m\n$\n" +
      std::string(72, '$') + "\n";
  const auto start = std::chrono::steady_clock::now();
  const auto e = data_error([&] { road::read_crg(text, "huge.crg"); });
  REQUIRE(e);
  CHECK(e->file() == "huge.crg");
  CHECK_THAT(e->what(), Catch::Contains("1e8"));
  CHECK(seconds_since(start) < 1.0);
}

TEST_CASE("ssrfleet refuses a billion trucks, sensors or particles within a second", "[cli][limits]") {
  test::TempDir dir;
  auto start = std::chrono::steady_clock::now();
  auto r = test::run_ssrfleet("simulate --trucks 1000000000 --out '" + dir.file("log.csv") + "'", dir);
  CHECK(seconds_since(start) < 1.0);
  CHECK(r.status == 64);
  CHECK_THAT(r.err, Catch::Contains("--trucks 1000000000: must be between 1 and 10000000"));
  // Past 2^64 is the same usage error, not an internal one.
  r = test::run_ssrfleet("simulate --trucks 99999999999999999999999 --out '" + dir.file("log.csv") + "'", dir);
  CHECK(r.status == 64);
  CHECK_THAT(r.err, Catch::Contains("must be between 1 and 10000000"));

  // A billion sensors: 8 GB of positions before anything looked at them.
  start = std::chrono::steady_clock::now();
  r = test::run_ssrfleet("simulate --trucks 1 --sensors 76,0.0000001,1000000000 --out '" + dir.file("log.csv") + "'", dir);
  CHECK(seconds_since(start) < 1.0);
  CHECK(r.status == 64);
  CHECK_THAT(r.err, Catch::Contains("sensors: count is 1000000000, but must be at most 10000"));

  start = std::chrono::steady_clock::now();
  r = test::run_ssrfleet("stream --particles 1000000000 --state '" + dir.file("state") + "'", dir);
  CHECK(seconds_since(start) < 1.0);
  CHECK(r.status == 64);
  CHECK_THAT(r.err, Catch::Contains("--particles 1000000000: must be between 2 and 10000000"));
}
