// The road summary: geometry, PSD fit and its roughness class, the wheel paths' IRI and the IRI
// across the road, missing cells, in text and JSON; from a surface, an OpenCRG file or ERD profiles.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "road/crg_reader.hpp"
#include "road/crg_writer.hpp"
#include "road/erd_format.hpp"
#include "road/iri.hpp"
#include "road/roughness_class.hpp"
#include "road/surface_presets.hpp"
#include "road/surface_summary.hpp"
#include "road/wheel_path.hpp"
#include "util/errors.hpp"

using namespace ssrfleet::road;

TEST_CASE("the summary of a preset describes its grid, PSD and IRI across the road", "[road][summary]") {
  const Surface s = preset_surface("AS1");
  const SurfaceSummary sum = summarize(s);
  CHECK(sum.name == "AS1");
  CHECK(sum.samples == 2001);
  CHECK(sum.lines == 101);
  CHECK(sum.length_m == Approx(100.0));
  CHECK(sum.width_m == Approx(5.0));
  CHECK(sum.rms_height_m > 0.0);
  CHECK(sum.psd.bins >= 3);
  // One surface's fitted level scatters by ~10 % (sd) and its slope by ~0.04: 3.5 sd bands.
  CHECK(sum.psd.gd_n0_m3 == Approx(20e-6).epsilon(0.35));
  CHECK(sum.psd.waviness == Approx(2.0).margin(0.15));
  REQUIRE(sum.iri_by_position.size() == 11);  // z = 0, 0.5, ..., 5.0
  CHECK(sum.iri_by_position.back().z_m == Approx(5.0));
  CHECK(sum.iri_by_position[3].iri_m_per_km == iri_m_per_km(wheel_path(s, 1.5), s.dx_m));
  CHECK(sum.iri_positions_measured == 11);
  CHECK(sum.iri_min_m_per_km <= sum.iri_mean_m_per_km);
  CHECK(sum.iri_mean_m_per_km <= sum.iri_max_m_per_km);

  const std::string text = to_text(sum);
  CHECK_THAT(text, Catch::Contains("AS1") && Catch::Contains("IRI") && Catch::Contains("PSD fit"));

  const nlohmann::json j = to_json(sum);
  CHECK(j.at("samples").get<long>() == 2001);
  CHECK(j.at("psd_fit").at("gd_n0_m3").get<double>() == sum.psd.gd_n0_m3);
  CHECK(j.at("iri").at("by_position").size() == 11);
  CHECK(j.at("iri").at("mean_m_per_km").get<double>() == sum.iri_mean_m_per_km);
}

TEST_CASE("the roughness class is labelled with its table, and the paper's older table reads one class better",
          "[road][summary]") {
  // ISO 8608:1995 bounds 32, 128, 512 ... e-6 m^3; the 1982 draft's 8, 32, 128, 512.
  CHECK(roughness_class(20e-6).label == "A");
  CHECK(roughness_class(20e-6, RoughnessTable::iso_draft_1982).label == "B");  // the paper's AS1, AS2
  CHECK(roughness_class(64e-6).label == "B");
  CHECK(roughness_class(64e-6, RoughnessTable::iso_draft_1982).label == "C");  // the paper's AS3
  CHECK(roughness_class(32e-6).label == "B");                                  // a lower bound belongs to its class
  CHECK(roughness_class(200e-3).label == "H");
  CHECK(roughness_class(1e-6, RoughnessTable::iso_draft_1982).label == "A");
  CHECK(roughness_class(5e-3, RoughnessTable::iso_draft_1982).label == "E");
  const RoughnessClass b = roughness_class(64e-6);
  CHECK(b.table == "ISO 8608:1995");
  CHECK(b.lower_m3 == 32e-6);
  CHECK(b.upper_m3 == 128e-6);
  CHECK(parse_roughness_table("paper") == RoughnessTable::iso_draft_1982);
  CHECK_THROWS_AS(parse_roughness_table("bs"), std::invalid_argument);

  // The presets' fitted levels (AS1 ~23e-6, AS3 ~64e-6 within the 35 % band of one surface) land
  // inside a class in both tables, as docs/model.md says.
  SummaryOptions paper;
  paper.table = RoughnessTable::iso_draft_1982;
  CHECK(summarize(preset_surface("AS1")).roughness_class.label == "A");
  CHECK(summarize(preset_surface("AS1"), paper).roughness_class.label == "B");
  const SurfaceSummary as3 = summarize(preset_surface("AS3"), paper);
  CHECK(as3.roughness_class.label == "C");
  CHECK(as3.roughness_class.table == "ISO draft 1982 (the paper's classes)");
  const nlohmann::json j = to_json(as3);
  CHECK(j.at("roughness_class").at("class") == "C");
  CHECK(j.at("roughness_class").at("table") == "ISO draft 1982 (the paper's classes)");
}

TEST_CASE("the wheel paths' IRI is reported, and missing cells are counted, mapped and skipped", "[road][summary]") {
  Surface s = preset_surface("AS1");
  SummaryOptions options;
  options.wheel_paths_m = {1.25, 3.75};
  const SurfaceSummary full = summarize(s, options);
  REQUIRE(full.wheel_paths.size() == 2);
  CHECK(full.wheel_paths[1].label == "z=3.75m");
  CHECK(full.wheel_paths[1].iri_m_per_km == iri_m_per_km(wheel_path(s, 3.75), s.dx_m));
  CHECK(full.wheel_paths[1].unavailable.empty());
  CHECK(full.missing_cells == 0);
  CHECK(full.psd_whole_lines);
  CHECK(full.psd_lines == 101);
  // Defaults: a 1.8 m track centred on the surface.
  CHECK(default_wheel_paths_m(s) == std::vector<double>{1.6, 3.4});

  // A hole along the right edge (lines 0 and 1, 2 m of road): counted and mapped; the IRI positions
  // over it report none, with the reason; the PSD is fitted on the complete lines.
  s.height_m.block(400, 0, 40, 2).setConstant(std::numeric_limits<double>::quiet_NaN());
  const SurfaceSummary holed = summarize(s, options);
  CHECK(holed.missing_cells == 80);
  REQUIRE(holed.missing.groups.size() == 1);
  CHECK(holed.missing.groups[0].line_end == 2);
  CHECK(std::isnan(holed.iri_by_position[0].iri_m_per_km));  // z = 0
  CHECK(holed.iri_by_position[0].unavailable == "crosses 40 missing cells between x = 20 and 21.95 m");
  CHECK(holed.iri_by_position[1].iri_m_per_km == full.iri_by_position[1].iri_m_per_km);  // z = 0.5: clear
  CHECK(holed.iri_positions_measured == 10);
  CHECK(holed.psd.bins > 0);
  CHECK(holed.psd_lines == 99);
  // The same road less 2 of its 101 lines in the mean periodogram.
  CHECK(holed.psd.gd_n0_m3 == Approx(full.psd.gd_n0_m3).epsilon(0.05));
  CHECK(holed.wheel_paths[0].iri_m_per_km == full.wheel_paths[0].iri_m_per_km);
  CHECK(to_json(holed).at("iri").at("by_position")[0].at("iri_m_per_km").is_null());
  CHECK(to_json(holed).at("iri").at("by_position")[0].at("unavailable") ==
        "crosses 40 missing cells between x = 20 and 21.95 m");
  CHECK(to_json(holed).at("missing_cells") == 80);

  // A wheel path between the two holed lines reads both: it has no IRI, and the summary says why
  // instead of refusing the road.
  options.wheel_paths_m = {0.02, 3.75};
  const SurfaceSummary over = summarize(s, options);
  REQUIRE(over.wheel_paths.size() == 2);
  CHECK(std::isnan(over.wheel_paths[0].iri_m_per_km));
  CHECK(over.wheel_paths[0].unavailable == "crosses 80 missing cells between x = 20 and 21.95 m");
  CHECK(over.wheel_paths[1].iri_m_per_km == full.wheel_paths[1].iri_m_per_km);
  CHECK_THAT(to_text(over), Catch::Contains("z=0.02m: IRI unavailable: it crosses 80 missing cells between x = 20 and "
                                            "21.95 m") &&
                                Catch::Contains("80 cells in 2 of 101 lines") &&
                                Catch::Contains("y = 0 .. 0.05 m (2 lines): 40 cells each, x = 20 .. 21.95 m"));
  // Driving the path is still refused (wheel_path.hpp), naming the surface and the hole.
  try {
    complete_wheel_path(s, 0.02);
    FAIL("a wheel path over missing cells was accepted");
  } catch (const ssrfleet::DataError& e) {
    CHECK_THAT(e.what(), Catch::Contains("AS1") && Catch::Contains("wheel path z = 0.02 m") &&
                             Catch::Contains("80 missing cells, the first at x = 20 m, y = 0 m"));
  }
}

TEST_CASE("a wheel path's IRI is the same from the surface, its OpenCRG file and its ERD profile", "[road][summary]") {
  const Surface s = preset_surface("AS3");
  std::ostringstream crg, erd;
  write_crg(s, crg);
  write_erd(wheel_path_profiles(s, default_wheel_paths_m(s)), erd);
  const SurfaceSummary direct = summarize(s);
  const SurfaceSummary from_crg = summarize(read_crg(crg.str(), "as3.crg").surface);
  const SurfaceSummary from_erd = summarize(read_erd(erd.str(), "as3.erd"));
  REQUIRE(from_erd.wheel_paths.size() == 2);
  for (std::size_t k = 0; k < 2; ++k) {
    CHECK(from_crg.wheel_paths[k].iri_m_per_km == direct.wheel_paths[k].iri_m_per_km);
    CHECK(from_erd.wheel_paths[k].iri_m_per_km == direct.wheel_paths[k].iri_m_per_km);
    CHECK(from_erd.wheel_paths[k].label == direct.wheel_paths[k].label);
  }
  CHECK(std::isnan(from_erd.wheel_paths[0].z_m));
  CHECK(from_erd.dy_m == 0.0);
  CHECK(from_erd.psd.bins > 0);
  CHECK(!from_erd.roughness_class.label.empty());
}
