#include <filesystem>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <limits>

#include "road/crg_reader.hpp"
#include "road/crg_writer.hpp"
#include "road/erd_format.hpp"
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

TEST_CASE("an OpenCRG road works wherever a road is taken: road, simulate, fit, predict, stream", "[cli][crg]") {
  test::TempDir dir;
  const std::string crg = dir.file("as2.crg"), log = dir.file("wim.csv"), posterior = dir.file("posterior.json");
  const auto written = run_ssrfleet("road AS2 --write '" + crg + "' --json", dir);
  INFO(written.err);
  REQUIRE(written.status == 0);
  const auto summary = nlohmann::json::parse(run_ssrfleet("road '" + crg + "' --json", dir).out);
  for (const char* key : {"length_m", "width_m", "dx_m", "dy_m", "rms_height_m", "psd_fit", "iri", "missing_cells",
                          "roughness_class"}) {
    CHECK(summary.contains(key));
  }
  CHECK(summary.at("missing_cells") == 0);
  CHECK(summary.at("roughness_class").at("table") == "ISO 8608:1995");
  CHECK(summary.at("iri").at("wheel_paths").size() == 2);
  CHECK(summary.at("iri").at("wheel_paths") == nlohmann::json::parse(written.out).at("iri").at("wheel_paths"));

  const auto on_crg = run_ssrfleet("simulate --road '" + crg + "' --trucks 6 --quiet --out '" + log + "'", dir);
  const auto on_preset = run_ssrfleet("simulate --road AS2 --trucks 6 --quiet", dir);
  REQUIRE(on_crg.status == 0);
  const std::string file_log = test::read_text(log);
  CHECK(file_log.substr(file_log.find('\n')) == on_preset.out.substr(on_preset.out.find('\n')));

  const auto fit = run_ssrfleet("fit '" + log + "' --road '" + crg + "' --particles 64 --quiet --out '" + posterior + "'", dir);
  INFO(fit.err);
  REQUIRE(fit.status == 0);
  const auto predict = run_ssrfleet("predict --posterior '" + posterior + "' --road '" + crg + "' --quiet", dir);
  INFO(predict.err);
  CHECK(predict.status == 0);  // the same site: the fingerprint of the .crg surface is the preset's
  const auto stream = run_ssrfleet("stream --state '" + dir.file("state") + "' --road '" + crg + "' --input '" + log +
                                       "' --particles 64 --quiet", dir);
  INFO(stream.err);
  CHECK(stream.status == 0);
}

TEST_CASE("missing road in the trucks' stretch is refused, elsewhere it is reported", "[cli][crg]") {
  test::TempDir dir;
  // A hand-written LRFI road, 100 m at 0.5 m by 3 long sections, with a hole at x = 99.5 m.
  const auto road_file = [&](const std::string& name, int hole_row) {
    std::string text = "$CT\ntest road\n$\n$ROAD_CRG\nREFERENCE_LINE_INCREMENT = 0.5\nLONG_SECTION_V_RIGHT = 0\n"
                       "LONG_SECTION_V_LEFT = 3\n$\n$KD_DEFINITION\n#:LRFI\nD:long section 1,m\nD:long section 2,m\n"
                       "D:long section 3,m\n$\n$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$$\n";
    for (int r = 0; r <= 200; ++r) {
      text += std::string(r == hole_row ? " *missing*" : " 0.0010000") + " 0.0020000 0.0030000\n";
    }
    test::write_text(dir.file(name), text);
    return dir.file(name);
  };
  const std::string past_sensors = road_file("past.crg", 199), in_stretch = road_file("in.crg", 100);
  const auto fine = run_ssrfleet("simulate --road '" + past_sensors + "' --trucks 3 --quiet", dir);
  INFO(fine.err);
  CHECK(fine.status == 0);
  CHECK_THAT(fine.err, Catch::Contains("1 missing cells"));
  const auto refused = run_ssrfleet("simulate --road '" + in_stretch + "' --trucks 3 --quiet", dir);
  CHECK(refused.status == 65);
  CHECK_THAT(refused.err, Catch::Contains(in_stretch) && Catch::Contains("missing cell, the first at x = 50 m, y = 0 m"));
  const auto summary = run_ssrfleet("road '" + in_stretch + "' --wheel-paths 2 --json", dir);
  INFO(summary.err);
  REQUIRE(summary.status == 0);
  CHECK(nlohmann::json::parse(summary.out).at("missing_cells") == 1);
  // Inspecting is not driving: a named wheel path over the hole has no IRI, and says why.
  const auto over_hole = run_ssrfleet("road '" + in_stretch + "' --wheel-paths 0.25", dir);
  INFO(over_hole.err);
  CHECK(over_hole.status == 0);
  CHECK_THAT(over_hole.out, Catch::Contains("z=0.25m: IRI unavailable: it crosses 1 missing cell at x = 50 m"));
}

namespace {

// AS1 (100 m x 5 m at 0.05 m) with two holes: 5 lines around the default left wheel path
// (y = 1.5 .. 1.7 m, z = 1.6 m lies on line 32) from x = 40 to 42 m, and the 2 right-edge lines
// from x = 50 to 50.95 m; written as a binary OpenCRG file, holes as NaN.
std::string write_holed_as1(const test::TempDir& dir) {
  road::Surface s = road::preset_surface("AS1");
  const double hole = std::numeric_limits<double>::quiet_NaN();
  s.height_m.block(800, 30, 41, 5).setConstant(hole);
  s.height_m.block(1000, 0, 20, 2).setConstant(hole);
  const std::string path = dir.file("holed.crg");
  road::write_crg_file(s, path);
  return path;
}

}  // namespace

TEST_CASE("road summarises an OpenCRG road whose wheel path crosses holes, and driving over them is refused",
          "[cli][crg]") {
  test::TempDir dir;
  const std::string crg = write_holed_as1(dir);
  const auto text = run_ssrfleet("road '" + crg + "'", dir);
  INFO(text.err);
  REQUIRE(text.status == 0);
  CHECK_THAT(text.out, Catch::Contains("missing     245 cells in 7 of 101 lines:"));
  CHECK_THAT(text.out, Catch::Contains("y = 0 .. 0.05 m (2 lines): 20 cells each, x = 50 .. 50.95 m"));
  CHECK_THAT(text.out, Catch::Contains("y = 1.5 .. 1.7 m (5 lines): 41 cells each, x = 40 .. 42 m"));
  CHECK_THAT(text.out, Catch::Contains("clear of holes: y = 0.1 .. 1.45, 1.75 .. 5 m"));
  CHECK_THAT(text.out, Catch::Contains("on 94 of 101 lines (those with no missing cell)"));
  CHECK_THAT(text.out, Catch::Contains("class       A in ISO 8608:1995"));
  CHECK_THAT(text.out, Catch::Contains("z=1.6m: IRI unavailable: it crosses 41 missing cells between x = 40 and 42 m"));
  CHECK_THAT(text.out, Catch::Contains("over 9 of 11 lateral positions"));

  // The wheel path clear of the holes keeps the whole road's IRI, to the bit.
  const auto holed = nlohmann::json::parse(run_ssrfleet("road '" + crg + "' --json", dir).out);
  const auto whole = nlohmann::json::parse(run_ssrfleet("road AS1 --json", dir).out);
  const auto& paths = holed.at("iri").at("wheel_paths");
  REQUIRE(paths.size() == 2);
  CHECK(paths[0].at("iri_m_per_km").is_null());
  CHECK(paths[0].at("unavailable") == "crosses 41 missing cells between x = 40 and 42 m");
  CHECK(paths[1].at("iri_m_per_km") == whole.at("iri").at("wheel_paths")[1].at("iri_m_per_km"));
  CHECK_FALSE(paths[1].contains("unavailable"));
  CHECK(holed.at("missing_cells") == 245);
  CHECK(holed.at("missing").at("lines_with_missing") == 7);
  CHECK(holed.at("missing").at("groups").size() == 2);
  CHECK(holed.at("missing").at("groups")[1].at("y_from_m").get<double>() == Approx(1.5));
  CHECK(holed.at("missing").at("x_to_m").get<double>() == Approx(50.95));
  CHECK(holed.at("psd_fit").at("lines") == 94);
  CHECK(holed.at("roughness_class").at("class") == "A");

  // Trucks cannot be driven over the holes: still exit 65, naming the file and the hole.
  const auto simulate = run_ssrfleet("simulate --road '" + crg + "' --trucks 3 --quiet", dir);
  CHECK(simulate.status == 65);
  CHECK_THAT(simulate.err, Catch::Contains(crg) && Catch::Contains("245 missing cells, the first at x = 40 m, y = 1.5 m"));
  const std::string log = dir.file("wim.csv");
  REQUIRE(run_ssrfleet("simulate --road AS1 --trucks 3 --quiet --out '" + log + "'", dir).status == 0);
  const auto fit = run_ssrfleet("fit '" + log + "' --road '" + crg + "' --particles 64 --quiet", dir);
  CHECK(fit.status == 65);
  CHECK_THAT(fit.err, Catch::Contains(crg) && Catch::Contains("missing cells"));
  const std::string posterior = dir.file("posterior.json");
  REQUIRE(run_ssrfleet("fit '" + log + "' --road AS1 --particles 64 --quiet --out '" + posterior + "'", dir).status == 0);
  const auto predict = run_ssrfleet("predict --posterior '" + posterior + "' --road '" + crg + "' --quiet", dir);
  CHECK(predict.status == 65);
  CHECK_THAT(predict.err, Catch::Contains(crg) && Catch::Contains("245 missing cells, the first at x = 40 m, y = 1.5 m"));
}

TEST_CASE("road refuses to convert holes into a format without a missing value, and keeps them in OpenCRG",
          "[cli][crg][erd]") {
  test::TempDir dir;
  const std::string crg = write_holed_as1(dir), erd = dir.file("paths.erd"), csv = dir.file("road.csv");
  // ERD has no missing-value marker: a wheel path over a hole is refused before anything is written.
  const auto over = run_ssrfleet("road '" + crg + "' --erd '" + erd + "'", dir);
  CHECK(over.status == 65);
  CHECK_THAT(over.err, Catch::Contains(crg) && Catch::Contains("--erd wheel path z = 1.6 m") &&
                           Catch::Contains("crosses 41 missing cells between x = 40 and 42 m") &&
                           Catch::Contains("positions clear of holes: y = 0.1 .. 1.45, 1.75 .. 5 m"));
  CHECK(over.out.empty());
  CHECK_FALSE(std::filesystem::exists(erd));
  // Paths on measured road are written, and read back with the summary's IRI.
  const auto clear = run_ssrfleet("road '" + crg + "' --erd '" + erd + "' --wheel-paths 1.0,3.4 --json", dir);
  INFO(clear.err);
  REQUIRE(clear.status == 0);
  const road::LongitudinalProfiles profiles = road::read_erd_file(erd);
  CHECK(profiles.profiles() == 2);
  CHECK(profiles.height_m.allFinite());
  const auto back = nlohmann::json::parse(run_ssrfleet("road '" + erd + "' --json", dir).out);
  CHECK(back.at("iri").at("wheel_paths")[1].at("iri_m_per_km") ==
        nlohmann::json::parse(clear.out).at("iri").at("wheel_paths")[1].at("iri_m_per_km"));
  // A road CSV cannot hold a hole either; an OpenCRG file keeps every one.
  const auto as_csv = run_ssrfleet("road '" + crg + "' --write '" + csv + "'", dir);
  CHECK(as_csv.status == 65);
  CHECK_THAT(as_csv.err, Catch::Contains("a road CSV has no marker for a missing height"));
  CHECK_FALSE(std::filesystem::exists(csv));
  const std::string copy = dir.file("copy.crg");
  REQUIRE(run_ssrfleet("road '" + crg + "' --write '" + copy + "' --crg-format LDFI", dir).status == 0);
  CHECK(road::read_crg_file(copy).report.missing_cells == 245);
}

TEST_CASE("a malformed OpenCRG road is refused with the file, the line and exit status 65", "[cli][crg]") {
  test::TempDir dir;
  const std::string path = dir.file("bad.crg");
  test::write_text(path, "$CT\n$\n$ROAD_CRG\nREFERENCE_LINE_INCREMENT = 1\n$\n$KD_DEFINITION\n#:LRFI\n"
                         "D:long section at v = 0,m\nD:long section at v = 1,m\n$\n$$$$$$$$$$\n"
                         " 0.0010000 0.0020000\n 0.0010000 0.0two000\n");
  for (const char* command : {"road", "simulate --quiet --road", "fit wim.csv --road"}) {
    const auto r = run_ssrfleet(std::string(command) + " '" + path + "'", dir);
    INFO(command << ": " << r.err);
    CHECK(r.status == 65);  // the road is read before fit's (absent) log
    CHECK_THAT(r.err, Catch::Contains(path + ":13") && Catch::Contains("'0.0two000' is not a number"));
  }
}

TEST_CASE("wheel-path profiles go out as ERD and come back as a road with the same IRI", "[cli][erd]") {
  test::TempDir dir;
  const std::string erd = dir.file("paths.erd");
  const auto out = run_ssrfleet("road AS1 --erd '" + erd + "' --wheel-paths 1.25,2.5 --classes paper --json", dir);
  INFO(out.err);
  REQUIRE(out.status == 0);
  const auto surface = nlohmann::json::parse(out.out);
  CHECK(surface.at("roughness_class").at("class") == "B");
  const auto back = run_ssrfleet("road '" + erd + "' --json", dir);
  INFO(back.err);
  REQUIRE(back.status == 0);
  const auto profiles = nlohmann::json::parse(back.out);
  REQUIRE(profiles.at("iri").at("wheel_paths").size() == 2);
  for (int k = 0; k < 2; ++k) {
    CHECK(profiles.at("iri").at("wheel_paths")[k].at("iri_m_per_km") ==
          surface.at("iri").at("wheel_paths")[k].at("iri_m_per_km"));
  }
  CHECK(profiles.at("iri").at("wheel_paths")[0].at("label") == "z=1.25m");
  CHECK(profiles.at("roughness_class").at("table") == "ISO 8608:1995");
  const auto simulate = run_ssrfleet("simulate --road '" + erd + "' --trucks 2", dir);
  CHECK(simulate.status == 64);
  CHECK_THAT(simulate.err, Catch::Contains("ERD file of longitudinal profiles"));
}
