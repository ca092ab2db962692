// ERD (ERDFILEV2.00) profiles in and out: a hand-written file with the units and spellings
// profilometers use, the round trip of ssrfleet's own wheel paths bit for bit, and bad input
// refused with the file, the line and the field.
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <functional>
#include <optional>
#include <sstream>
#include <string>

#include "road/erd_format.hpp"
#include "road/surface_presets.hpp"
#include "road/wheel_path.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;
using namespace ssrfleet::road;

namespace {

// Two profiles in millimetres, 5 samples at 0.25 ft, values split over lines, commas and a D
// exponent: everything the format allows.
const std::string kErd =
    "ERDFILEV2.00\n"
    "      2,      5,     -1,      1,      5,       0.2500,     -1,\n"
    "TITLE   hand-written test profiles\n"
    "SHORTNAMleft    right\n"
    "UNITSNAMmm      mm\n"
    "XUNITS  ft\n"
    "END\n"
    " 1.0 2.0\n"
    " 1.5, -2.5\n"
    " 0.0 0.0 3.0D-01\n"
    " 4.0\n"
    " 5.0 6.0\n";

using test::data_error;

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  text.replace(text.find(from), from.size(), to);
  return text;
}

}  // namespace

TEST_CASE("a hand-written ERD file reads into profiles in metres", "[road][erd]") {
  const LongitudinalProfiles p = read_erd(kErd, "hand.erd");
  CHECK(p.name == "hand.erd");
  REQUIRE(p.profiles() == 2);
  REQUIRE(p.samples() == 5);
  CHECK(p.labels == std::vector<std::string>{"left", "right"});
  CHECK(p.dx_m == Approx(0.25 * 0.3048));
  CHECK(p.height_m(0, 0) == Approx(1e-3));
  CHECK(p.height_m(1, 1) == Approx(-2.5e-3));
  CHECK(p.height_m(3, 0) == Approx(0.3e-3));  // D exponent
  CHECK(p.height_m(3, 1) == Approx(4e-3));    // a row split over two lines
  CHECK(p.height_m(4, 1) == Approx(6e-3));
}

TEST_CASE("wheel paths written as ERD read back bit for bit", "[road][erd]") {
  const Surface s = preset_surface("AS3");
  const LongitudinalProfiles paths = wheel_path_profiles(s, {1.6, 3.4, 2.225});
  std::ostringstream os;
  write_erd(paths, os);
  const LongitudinalProfiles back = read_erd(os.str(), "paths.erd");
  CHECK(back.dx_m == s.dx_m);
  CHECK(back.labels == std::vector<std::string>{"z=1.6m", "z=3.4m", "z=2.225m"});
  REQUIRE(back.height_m.rows() == paths.height_m.rows());
  REQUIRE(back.height_m.cols() == 3);
  CHECK((back.height_m == paths.height_m).all());
  CHECK((back.height_m.col(0) == wheel_path(s, 1.6)).all());
}

TEST_CASE("bad ERD input is refused naming the file, the line and the field", "[road][erd]") {
  SECTION("not an ERD file") {
    const auto e = data_error([] { read_erd("x_m,0,1\n", "not.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 1);
  }
  SECTION("truncated data") {
    const std::string cut = kErd.substr(0, kErd.rfind(" 5.0"));
    const auto e = data_error([&] { read_erd(cut, "cut.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 11);
    CHECK_THAT(e->what(), Catch::Contains("cut.erd:11") && Catch::Contains("truncated") &&
                              Catch::Contains("= 10 values, the data hold 8"));
  }
  SECTION("counts that disagree with the header: more values") {
    const auto e = data_error([&] { read_erd(kErd + " 7.0\n", "long.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 13);
    CHECK_THAT(e->what(), Catch::Contains("more values than the header's 5 samples"));
  }
  SECTION("a non-numeric value") {
    const auto e = data_error([&] { read_erd(replaced(kErd, "4.0", "4.O"), "bad.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 11);
    CHECK(e->field() == "channel 2");
    CHECK_THAT(e->what(), Catch::Contains("sample 4: '4.O' is not a finite number"));
  }
  SECTION("an absurd size, refused before anything is allocated") {
    const auto e = data_error([&] { read_erd(replaced(kErd, "      5,", "  9e12,"), "huge.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 2);
    CHECK_THAT(e->what(), Catch::Contains("more than the 1e8 values"));
  }
  SECTION("a malformed format line, an unknown unit, no END") {
    auto e = data_error([&] { read_erd(replaced(kErd, "0.2500", "x"), "dt.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 2);
    CHECK(e->field() == "format line field 6");
    e = data_error(
        [&] { read_erd(replaced(kErd, "UNITSNAMmm      mm", "UNITSNAMmm      furlong"), "unit.erd"); });
    REQUIRE(e);
    CHECK(e->line() == 5);
    CHECK_THAT(e->what(), Catch::Contains("unknown unit 'furlong' of channel 2"));
    e = data_error([&] { read_erd(replaced(kErd, "END\n", "\n"), "open.erd"); });
    REQUIRE(e);
    CHECK_THAT(e->what(), Catch::Contains("no END line"));
  }
}
