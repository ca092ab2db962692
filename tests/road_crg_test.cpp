// OpenCRG in and out: hand-written files from the specification in each data type, the grid and
// the missing cells they describe, the warnings for what the surface leaves out, round trips
// (bit for bit in binary, to the stated precision in text), and every kind of bad input refused
// with the file and the line or byte offset.
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include "road/crg_reader.hpp"
#include "road/crg_writer.hpp"
#include "road/missing_cells.hpp"
#include "road/surface_presets.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;
using namespace ssrfleet::road;

namespace {

const std::string kEnd = std::string(72, '$') + "\n";

// The header of a small road: `road` and `definition` are the bodies of $ROAD_CRG and $KD_DEFINITION.
std::string header(const std::string& road, const std::string& definition) {
  return "* a test road written by hand from the OpenCRG specification\n"
         "$CT\nhand-written test road\n$\n"
         "$ROAD_CRG ! road parameters\n" +
         road +
         "$!**********\n"
         "$KD_DEFINITION\n" +
         definition + "$!**********\n" + kEnd;
}

// The spec's LRFI layout: 10-character fields (they may touch: "0.0000000-0.0011111"), a heading
// channel first, `*missing*` placeholders, a Fortran D exponent.
const std::string kLrfi = header(
                              "REFERENCE_LINE_START_U   = 10.0\n"
                              "REFERENCE_LINE_END_U     = 11.5  ! 4 cross sections\n"
                              "REFERENCE_LINE_INCREMENT = 0.5\n"
                              "LONG_SECTION_V_RIGHT     = -0.50\n"
                              "LONG_SECTION_V_LEFT      =  0.50\n"
                              "LONG_SECTION_V_INCREMENT =  0.50\n",
                              "#:LRFI\n"
                              "D:reference line phi,rad\n"
                              "D:long section 1,m  ! right edge\n"
                              "D:long section 2,m\n"
                              "D:long section 3,m  ! left edge\n") +
                          " *missing* 0.0010000 0.0020000 0.0030000\n"
                          " 0.0000000-0.0011111 *missing* 0.0000000\n"
                          " 0.0100000 0.0005000 0.0004000-0.0002500\n"
                          " 0.0200000 1.250D-03 0.0000000 0.0000000\n";

using test::data_error;

void append_big_endian_float(std::string& out, float v) {
  const auto u = std::bit_cast<std::uint32_t>(v);
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((u >> shift) & 0xff);
}

std::string written(const Surface& s, CrgDataFormat f) {
  std::ostringstream os;
  write_crg(s, os, f);
  return os.str();
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

}  // namespace

TEST_CASE("a hand-written LRFI file reads into the grid it describes, missing cell and all", "[road][crg]") {
  const CrgRoad road = read_crg(kLrfi, "hand.crg");
  const Surface& s = road.surface;
  CHECK(s.name == "hand.crg");
  REQUIRE(s.samples() == 4);
  REQUIRE(s.lines() == 3);
  CHECK(s.dx_m == 0.5);
  CHECK(s.y0_m == -0.5);  // long section 1 is the right edge, v = y
  CHECK(s.dy_m == 0.5);
  CHECK(s.height_m(0, 0) == 0.001);
  CHECK(s.height_m(0, 2) == 0.003);
  CHECK(s.height_m(1, 0) == -0.0011111);  // touching fields
  CHECK(std::isnan(s.height_m(1, 1)));
  CHECK(s.height_m(2, 2) == -0.00025);
  CHECK(s.height_m(3, 0) == 1.25e-3);  // D exponent
  CHECK(road.report.format == CrgDataFormat::lrfi);
  CHECK(road.report.missing_cells == 1);  // the heading's placeholder is not a cell
  // The heading changes from 0 to 0.02 rad (the first value is unused): curved, with a warning.
  REQUIRE(road.report.warnings.size() == 1);
  CHECK_THAT(road.report.warnings[0], Catch::Contains("curved") && Catch::Contains("0.02 rad") &&
                                          Catch::Contains("mapped along the reference line"));
}

TEST_CASE("placed long sections in any order, rows wrapped over lines, and a sloped line (LDFI)",
          "[road][crg]") {
  // v in shuffled order; 6 channels of 20 characters take 2 lines per row (4 + 2).
  const double v[] = {1.0, -1.0, 0.0, 0.5, -0.5};
  std::string definition = "#:LDFI\nD:reference line slope,m/m\n";
  for (const double x : v) definition += "D:long section at v = " + std::to_string(x) + ",m\n";
  std::string text = header("REFERENCE_LINE_INCREMENT = 0.25\n", definition);
  const auto field = [](double x) {
    char b[32];
    std::snprintf(b, sizeof b, "%20.10f", x);
    return std::string(b);
  };
  for (int r = 0; r < 3; ++r) {
    text += field(0.01) + field(1e-3 * r + 1e-4 * v[0]) + field(1e-3 * r + 1e-4 * v[1]) +
            field(1e-3 * r + 1e-4 * v[2]) + "\n" + field(1e-3 * r + 1e-4 * v[3]) +
            field(1e-3 * r + 1e-4 * v[4]) + "\n";
  }
  const CrgRoad road = read_crg(text, "placed.crg");
  const Surface& s = road.surface;
  REQUIRE(s.samples() == 3);
  REQUIRE(s.lines() == 5);
  CHECK(s.y0_m == -1.0);
  CHECK(s.dy_m == 0.5);
  for (Eigen::Index r = 0; r < 3; ++r) {
    for (Eigen::Index j = 0; j < 5; ++j) {
      const double y = s.lateral_m(j);
      CHECK(s.height_m(r, j) == Approx(1e-3 * static_cast<double>(r) + 1e-4 * y).margin(1e-12));
    }
  }
  REQUIRE(road.report.warnings.size() == 1);
  CHECK_THAT(road.report.warnings[0], Catch::Contains("sloped (up to 0.01 m/m"));
}

TEST_CASE("unevenly placed long sections on a grid are resampled as a wheel path reads them", "[road][crg]") {
  const std::string text = header("REFERENCE_LINE_INCREMENT = 1\n",
                                  "#:LRFI\nD:long section at v = -1,m\nD:long section at v = -0.5,m\n"
                                  "D:long section at v = 0,m\nD:long section at v = 1,m\n") +
                           " 0.0010000 0.0020000 0.0030000 0.0050000\n"
                           " 0.0010000 0.0020000 0.0030000 0.0070000\n";
  const CrgRoad road = read_crg(text, "uneven.crg");
  REQUIRE(road.surface.lines() == 5);  // -1, -0.5, 0, 0.5, 1
  CHECK(road.surface.dy_m == 0.5);
  CHECK(road.surface.height_m(0, 3) == Approx(0.004));  // halfway between v = 0 and v = 1
  CHECK(road.surface.height_m(1, 3) == Approx(0.005));
  CHECK(road.surface.height_m(1, 4) == 0.007);
  CHECK_THAT(road.report.warnings.back(), Catch::Contains("resampled onto 5 lines"));

  const std::string off_grid = header("REFERENCE_LINE_INCREMENT = 1\n",
                                      "#:LRFI\nD:long section at v = 0,m\nD:long section at v = 0.3,m\n"
                                      "D:long section at v = 0.5,m\n") +
                               " 0.0010000 0.0020000 0.0030000\n 0.0010000 0.0020000 0.0030000\n";
  const auto e = data_error([&] { read_crg(off_grid, "offgrid.crg"); });
  REQUIRE(e);
  CHECK(e->line() == 11);  // the 'at v = 0.3' definition
  CHECK_THAT(e->what(), Catch::Contains("offgrid.crg:11") && Catch::Contains("not on the grid"));
}

TEST_CASE("a hand-built KRBI payload: the default data type, NaN cells and NaN padding", "[road][crg]") {
  // No "#:" line: the specification's default, KRBI. 5 rows of 3 floats (60 bytes), padded with
  // NaNs to the 80-byte record; no REFERENCE_LINE_END_U, so the rows come from the payload.
  std::string bytes = header("REFERENCE_LINE_INCREMENT = 0.1\nLONG_SECTION_V_INCREMENT = 0.2\n",
                             "D:long section 1,m\nD:long section 2,m\nD:long section 3,m\n");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 3; ++c)
      append_big_endian_float(bytes, r == 2 && c == 0 ? nan : 0.001f * static_cast<float>(r * 3 + c));
  }
  for (int k = 0; k < 5; ++k) append_big_endian_float(bytes, nan);
  const CrgRoad road = read_crg(bytes, "kr.crg");
  CHECK(road.report.format == CrgDataFormat::krbi);
  REQUIRE(road.surface.samples() == 5);
  REQUIRE(road.surface.lines() == 3);
  CHECK(road.surface.y0_m == Approx(-0.2));  // only the increment given: centred on the reference line
  CHECK(road.surface.height_m(4, 2) == static_cast<double>(0.001f * 14.0f));
  CHECK(std::isnan(road.surface.height_m(2, 0)));
  CHECK(road.report.missing_cells == 1);
  CHECK(road.report.warnings.empty());
}

TEST_CASE("a surface written as KDBI reads back bit for bit, missing cells included, and KRBI to float",
          "[road][crg]") {
  Surface s = preset_surface("AS2");
  s.height_m.col(0).segment(1500, 20).setConstant(std::numeric_limits<double>::quiet_NaN());
  const CrgRoad back = read_crg(written(s, CrgDataFormat::kdbi), "as2.crg");
  REQUIRE(back.surface.samples() == s.samples());
  REQUIRE(back.surface.lines() == s.lines());
  CHECK(same_bits(back.surface.dx_m, s.dx_m));
  CHECK(same_bits(back.surface.y0_m, s.y0_m));
  CHECK(same_bits(back.surface.dy_m, s.dy_m));
  Eigen::Index differing = 0;
  for (Eigen::Index k = 0; k < s.height_m.size(); ++k) {
    const double a = s.height_m.data()[k], b = back.surface.height_m.data()[k];
    if (!(same_bits(a, b) || (std::isnan(a) && std::isnan(b)))) ++differing;
  }
  CHECK(differing == 0);
  CHECK(back.report.missing_cells == 20);
  CHECK(back.report.warnings.empty());

  const CrgRoad as_float = read_crg(written(s, CrgDataFormat::krbi), "as2f.crg");
  const Eigen::ArrayXXd rounded = s.height_m.cast<float>().cast<double>();
  CHECK(((as_float.surface.height_m == rounded) || (rounded.isNaN() && as_float.surface.height_m.isNaN()))
            .all());
}

TEST_CASE("a surface written as LDFI or LRFI reads back to the stated text precision exactly",
          "[road][crg]") {
  Surface s = preset_surface("AS1");
  s.height_m.conservativeResize(400, 7);  // a corner is enough; 7 lines wrap LDFI rows over 2 lines
  const auto through = [](double v, const char* format, int precision) {
    char b[64];
    std::snprintf(b, sizeof b, format, precision, v);
    return std::strtod(b, nullptr);
  };
  const Surface ldfi = read_crg(written(s, CrgDataFormat::ldfi), "t.crg").surface;
  const Surface lrfi = read_crg(written(s, CrgDataFormat::lrfi), "t.crg").surface;
  REQUIRE(ldfi.height_m.rows() == 400);
  REQUIRE(lrfi.height_m.cols() == 7);
  Eigen::Index off_ldfi = 0, off_lrfi = 0;
  for (Eigen::Index k = 0; k < s.height_m.size(); ++k) {
    const double v = s.height_m.data()[k];
    REQUIRE(std::abs(v) < 1.0);
    if (ldfi.height_m.data()[k] != through(v, "%.*e", 13)) ++off_ldfi;  // 14 significant digits
    if (lrfi.height_m.data()[k] != through(v, "%.*f", 7)) ++off_lrfi;   // 1e-7 m
  }
  CHECK(off_ldfi == 0);
  CHECK(off_lrfi == 0);
  CHECK(crg_text_field(-1.5e-3, CrgDataFormat::lrfi) == "-0.0015000");
  CHECK(crg_text_field(std::nan(""), CrgDataFormat::ldfi) == "           *missing*");
  CHECK(crg_text_field(-123.5, CrgDataFormat::lrfi) == "-1.235e+02");  // too wide for fixed point
}

TEST_CASE("the geometry that is not applied is named: banking, modifiers, unknown channels", "[road][crg]") {
  const std::string text = header(
                               "REFERENCE_LINE_INCREMENT = 1\nREFERENCE_LINE_START_B = 0.03\n"
                               "LONG_SECTION_V_RIGHT = 0\nLONG_SECTION_V_LEFT = 1\n",
                               "#:LRFI\nD:long section 1,m\nD:friction coefficient,-\nD:long section 2,m\n") +
                           " 0.0010000 0.8000000 0.0020000\n 0.0010000 0.8000000 0.0020000\n";
  const std::string with_mods = text.substr(0, text.find("$KD_DEFINITION")) +
                                "$ROAD_CRG_MODS\nSCALE_Z_GRID = 2\n$\n" +
                                text.substr(text.find("$KD_DEFINITION"));
  const CrgRoad road = read_crg(with_mods, "banked.crg");
  CHECK(road.surface.lines() == 2);
  CHECK(road.surface.height_m(1, 1) == 0.002);  // the friction column is read past
  std::string all;
  for (const auto& w : road.report.warnings) all += w + "\n";
  CHECK_THAT(all, Catch::Contains("banked (up to 0.03 m/m") && Catch::Contains("$ROAD_CRG_MODS") &&
                      Catch::Contains("friction coefficient"));
}

TEST_CASE("bad OpenCRG input is refused naming the file and the line or byte offset", "[road][crg]") {
  SECTION("a truncated binary payload: byte offset") {
    Surface s = preset_surface("AS1");
    s.height_m.conservativeResize(50, 4);
    std::string bytes = written(s, CrgDataFormat::kdbi);
    bytes.resize(bytes.size() - 96);  // three whole cross sections short
    const auto e = data_error([&] { read_crg(bytes, "cut.crg"); });
    REQUIRE(e);
    CHECK(e->file() == "cut.crg");
    CHECK_THAT(e->what(), Catch::Contains("truncated") &&
                              Catch::Contains("byte offset " + std::to_string(bytes.size())));
    // Without REFERENCE_LINE_END_U the cut shows as a partial cross section.
    std::string no_end = bytes;
    const std::size_t at = no_end.find("REFERENCE_LINE_END_U");
    no_end.replace(at, no_end.find('\n', at) - at, "* end of u left out");
    no_end.resize(no_end.size() - 3);  // inside a value
    const auto e2 = data_error([&] { read_crg(no_end, "cut2.crg"); });
    REQUIRE(e2);
    CHECK_THAT(e2->what(), Catch::Contains("truncated") && Catch::Contains("byte offset"));
  }
  SECTION("a truncated text payload: a cross section missing its second line") {
    Surface s = preset_surface("AS1");
    s.height_m.conservativeResize(10, 6);  // LDFI: 2 lines per row
    std::string text = written(s, CrgDataFormat::ldfi);
    text.resize(text.rfind('\n', text.size() - 2) + 1);  // drop the last line
    const auto e = data_error([&] { read_crg(text, "cut.crg"); });
    REQUIRE(e);
    const std::size_t lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
    CHECK(e->line() == lines);
    CHECK_THAT(e->what(), Catch::Contains("truncated") && Catch::Contains("1 of its 2 lines"));
  }
  SECTION("counts that disagree with the header") {
    std::string text = kLrfi;
    text.replace(text.find("11.5"), 4, "12.5");  // 6 cross sections declared, 4 given
    auto e = data_error([&] { read_crg(text, "short.crg"); });
    REQUIRE(e);
    CHECK_THAT(e->what(), Catch::Contains("declares 6 cross sections, the payload holds 4"));
    text = kLrfi;
    text.replace(text.find("11.5"), 4, "11.0");  // 3 declared, 4 given
    e = data_error([&] { read_crg(text, "long.crg"); });
    REQUIRE(e);
    CHECK_THAT(e->what(), Catch::Contains("counts disagree"));
    CHECK(e->line() == 24);  // the first row past the declared ones
    text = kLrfi;
    text.replace(text.find("=  0.50\n"), 8, "=  1.50\n");  // V_LEFT 1.5 at 0.5: 5 long sections, 3 defined
    e = data_error([&] { read_crg(text, "lat.crg"); });
    REQUIRE(e);
    CHECK(e->line() == 10);
    CHECK_THAT(e->what(), Catch::Contains("counts disagree") && Catch::Contains("defines 3"));
  }
  SECTION("a non-numeric cell: line and column") {
    std::string text = kLrfi;
    text.replace(text.find(" 0.0004000"), 10, " 0.00O4000");
    const auto e = data_error([&] { read_crg(text, "nan.crg"); });
    REQUIRE(e);
    CHECK(e->line() == 23);
    CHECK(e->field() == "channel 3 (column 21)");
    CHECK_THAT(e->what(), Catch::Contains("nan.crg:23") && Catch::Contains("'0.00O4000' is not a number"));
    text = kLrfi;  // a NaN written out is not the '*' placeholder of a missing value
    text.replace(text.find(" 0.0004000"), 10, "       nan");
    const auto e2 = data_error([&] { read_crg(text, "nan.crg"); });
    REQUIRE(e2);
    CHECK(e2->line() == 23);
  }
  SECTION("an unknown data type") {
    std::string text = kLrfi;
    text.replace(text.find("#:LRFI"), 6, "#:LXFI");
    const auto e = data_error([&] { read_crg(text, "type.crg"); });
    REQUIRE(e);
    CHECK(e->line() == 14);
    CHECK_THAT(e->what(), Catch::Contains("unknown data type 'LXFI'") && Catch::Contains("KDBI"));
  }
  SECTION("an absurd size is refused before anything is allocated") {
    std::string text = kLrfi;
    text.replace(text.find("11.5"), 4, "1e15");
    const auto e = data_error([&] { read_crg(text, "huge.crg"); });
    REQUIRE(e);
    CHECK(e->line() == 7);
    CHECK_THAT(e->what(), Catch::Contains("more than the 1e8 values"));
  }
  SECTION("a header that never ends, or lacks its sections") {
    const std::string no_end = kLrfi.substr(0, kLrfi.find(kEnd));
    auto e = data_error([&] { read_crg(no_end, "open.crg"); });
    REQUIRE(e);
    CHECK_THAT(e->what(), Catch::Contains("the header never ends"));
    std::string no_increment = kLrfi;
    no_increment.replace(no_increment.find("REFERENCE_LINE_INCREMENT"), 8, "*EFERENC");
    e = data_error([&] { read_crg(no_increment, "inc.crg"); });
    REQUIRE(e);
    CHECK_THAT(e->what(), Catch::Contains("REFERENCE_LINE_INCREMENT"));
  }
}
