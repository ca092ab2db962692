#include <filesystem>

#include <catch2/catch.hpp>

#include "road/surface_csv.hpp"
#include "road/surface_presets.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

TEST_CASE("ssrfleet road writes a preset that reads back bit-identical and summarises it", "[cli]") {
  test::TempDir dir;
  const std::string path = dir.file("as2.csv");
  const auto r = run_ssrfleet("road AS2 --write '" + path + "' --json", dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  const road::Surface back = road::read_surface_csv_file(path);
  const road::Surface preset = road::preset_surface("AS2");
  CHECK((back.height_m == preset.height_m).all());
  CHECK(r.out.find("\"iri") != std::string::npos);
  // A measured surface stands in for a preset: simulating on the file equals simulating on AS2.
  const auto on_file = run_ssrfleet("simulate --road '" + path + "' --trucks 5 --quiet", dir);
  const auto on_preset = run_ssrfleet("simulate --road AS2 --trucks 5 --quiet", dir);
  REQUIRE(on_file.status == 0);
  REQUIRE(on_preset.status == 0);
  const auto body = [](const std::string& s) { return s.substr(s.find('\n')); };  // past the comment line
  CHECK(body(on_file.out) == body(on_preset.out));
}

TEST_CASE("a road file with uneven spacing is refused with file line and field and no output", "[cli]") {
  test::TempDir dir;
  const std::string road = dir.file("road.csv"), out = dir.file("out.csv");
  std::string text = "x_m,0,0.5,1.0\n";
  for (int i = 0; i <= 2000; ++i) {
    const double x = i == 7 ? 0.36 : 0.05 * i;  // row 7 (file line 9) is off the grid
    text += std::to_string(x) + ",0.001,0.002,0.003\n";
  }
  test::write_text(road, text);
  const auto r = run_ssrfleet("simulate --road '" + road + "' --trucks 3 --out '" + out + "'", dir);
  CHECK(r.status == 65);
  CHECK(r.err.find(road) != std::string::npos);
  CHECK(r.err.find("x_m") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(out));
  const auto summary = run_ssrfleet("road '" + road + "'", dir);
  CHECK(summary.status == 65);
}

TEST_CASE("ssrfleet without a command or with an unknown one is a usage error", "[cli]") {
  test::TempDir dir;
  CHECK(run_ssrfleet("", dir).status == 64);
  const auto unknown = run_ssrfleet("frobnicate", dir);
  CHECK(unknown.status == 64);
  CHECK(unknown.err.find("unknown command") != std::string::npos);
  const auto help = run_ssrfleet("--help", dir);
  CHECK(help.status == 0);
  CHECK(help.out.find("simulate") != std::string::npos);
  const auto sub_help = run_ssrfleet("simulate --help", dir);
  CHECK(sub_help.status == 0);
  CHECK(sub_help.out.find("--noise") != std::string::npos);
}
