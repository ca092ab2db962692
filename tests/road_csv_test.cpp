// The road-surface CSV of docs/site-data.md: exact round trip, and every defect named by file, line
// and field.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "road/surface_csv.hpp"
#include "road/surface_presets.hpp"
#include "util/errors.hpp"

using namespace ssrfleet::road;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path;
  TempDir() : path(fs::temp_directory_path() / ("ssrfleet_road_csv_" + std::to_string(::getpid()))) {
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const fs::path file = path / name;
    std::ofstream(file) << text;
    return file.string();
  }
};

}  // namespace

TEST_CASE("writing and reading a surface CSV gives the same doubles bit for bit", "[road][csv]") {
  const TempDir dir;
  Surface s = preset_surface("AS1");
  s.y0_m = 0.1;  // a lateral origin that is not 0 makes y0 + j dy round
  s.dy_m = 0.05;
  const std::string file = (dir.path / "as1.csv").string();
  write_surface_csv_file(s, file);
  const Surface r = read_surface_csv_file(file);
  CHECK(r.dx_m == s.dx_m);
  CHECK(r.y0_m == s.y0_m);
  CHECK(r.dy_m == s.dy_m);
  REQUIRE(r.samples() == s.samples());
  REQUIRE(r.lines() == s.lines());
  CHECK((r.height_m == s.height_m).all());
  CHECK(r.name == file);
  // No temporary left behind.
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path)) ++entries;
  CHECK(entries == 1);
}

TEST_CASE("comments, blank lines, blanks around cells and a non-zero first x are accepted", "[road][csv]") {
  std::istringstream in(
      "# a comment\n\n  x_m , 0.5 , 1.0\r\n10.0,0.001,0.002\n  # another\n10.1,0.003,0.004\n10.2,0.005,0.006\n");
  const Surface s = read_surface_csv(in, "inline.csv");
  CHECK(s.samples() == 3);
  CHECK(s.lines() == 2);
  CHECK(s.dx_m == Approx(0.1).epsilon(1e-12));
  CHECK(s.y0_m == 0.5);
  CHECK(s.dy_m == 0.5);
  CHECK(s.height_m(2, 1) == 0.006);
}

TEST_CASE("every malformed surface CSV is a DataError naming file, line and field", "[road][csv]") {
  const TempDir dir;
  struct Case {
    const char* name;
    const char* text;
    int line;
    const char* field;
  };
  const Case cases[] = {
      {"ragged", "x_m,0,0.5\n0,1,2\n0.1,1\n", 3, "columns"},
      {"non_numeric", "x_m,0,0.5\n0,1,2\n0.1,1,abc\n", 3, "0.5"},
      {"nan", "# c\nx_m,0,0.5\n0,nan,2\n0.1,1,2\n", 3, "0"},
      {"inf", "x_m,0,0.5\n0,1,2\n0.1,1,inf\n", 3, "0.5"},
      {"bad_header", "distance,0,0.5\n0,1,2\n", 1, "x_m"},
      {"lateral_header", "x_m,0,left\n0,1,2\n", 1, "left"},
      {"one_row", "x_m,0,0.5\n0,1,2\n", 2, "x_m"},
      {"no_rows", "x_m,0,0.5\n", 1, "x_m"},
      {"one_line", "x_m,0\n0,1\n0.1,2\n", 1, "header"},
      {"uneven_x", "x_m,0,0.5\n0,1,2\n0.1,1,2\n0.25,1,2\n", 4, "x_m"},
      {"decreasing_x", "x_m,0,0.5\n0,1,2\n-0.1,1,2\n", 3, "x_m"},
      {"uneven_y", "x_m,0,0.5,1.2\n0,1,2,3\n0.1,1,2,3\n", 1, "1.2"},
      {"decreasing_y", "x_m,0,0.5,0.5\n0,1,2,3\n0.1,1,2,3\n", 1, "0.5"},
  };
  for (const Case& c : cases) {
    const std::string file = dir.write(std::string(c.name) + ".csv", c.text);
    INFO(c.name);
    try {
      read_surface_csv_file(file);
      FAIL("no DataError");
    } catch (const ssrfleet::DataError& e) {
      const std::string what = e.what();
      CHECK_THAT(what, Catch::Contains(file) && Catch::Contains(":" + std::to_string(c.line) + ":") &&
                           Catch::Contains("'" + std::string(c.field) + "'"));
      CHECK(e.line() == static_cast<std::size_t>(c.line));
      CHECK(e.field() == c.field);
    }
  }
}

TEST_CASE("a missing surface file is a MissingInputError naming the path", "[road][csv]") {
  const TempDir dir;
  const std::string file = (dir.path / "nowhere.csv").string();
  try {
    read_surface_csv_file(file);
    FAIL("no MissingInputError");
  } catch (const ssrfleet::MissingInputError& e) {
    CHECK_THAT(std::string(e.what()), Catch::Contains(file));
  }
}

TEST_CASE("a surface CSV that cannot be written is an IoError and leaves nothing behind", "[road][csv]") {
  const TempDir dir;
  Surface s;
  s.height_m = Eigen::ArrayXXd::Zero(3, 2);
  const std::string file = (dir.path / "no_such_dir" / "out.csv").string();
  CHECK_THROWS_AS(write_surface_csv_file(s, file), ssrfleet::IoError);
  CHECK_FALSE(fs::exists(dir.path / "no_such_dir"));
}

TEST_CASE("a surface with a missing height is not written as CSV, which has no missing value", "[road][csv]") {
  const TempDir dir;
  Surface s;
  s.name = "holed";
  s.height_m = Eigen::ArrayXXd::Zero(3, 2);
  s.height_m(1, 1) = std::numeric_limits<double>::quiet_NaN();
  const std::string file = (dir.path / "out.csv").string();
  CHECK_THROWS_AS(write_surface_csv_file(s, file), std::invalid_argument);
  CHECK_FALSE(fs::exists(file));
  CHECK(fs::is_empty(dir.path));  // nor the temporary
}
