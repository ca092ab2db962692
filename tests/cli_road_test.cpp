#include <filesystem>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

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
  const auto over_hole = run_ssrfleet("road '" + in_stretch + "' --wheel-paths 0.25", dir);
  CHECK(over_hole.status == 65);
  CHECK_THAT(over_hole.err, Catch::Contains("wheel path z = 0.25 m"));
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
