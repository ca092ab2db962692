// Where a surface's holes are (map_missing, describe_span) and which part of it a roughness fit
// reads (measured_part): a road with holes is described, never refused.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>

#include "road/measured_part.hpp"
#include "road/missing_cells.hpp"
#include "road/missing_map.hpp"
#include "road/psd_estimate.hpp"
#include "road/surface_presets.hpp"
#include "road/surface_summary.hpp"

using namespace ssrfleet::road;

namespace {

constexpr double kHole = std::numeric_limits<double>::quiet_NaN();

// 10 m at 0.5 m by 5 lines at 0.25 m from y = -0.5 m, heights 0.001 m.
Surface small_surface() {
  Surface s;
  s.name = "small";
  s.dx_m = 0.5;
  s.y0_m = -0.5;
  s.dy_m = 0.25;
  s.height_m = Eigen::ArrayXXd::Constant(21, 5, 0.001);
  return s;
}

}  // namespace

TEST_CASE("missing cells are mapped by groups of lines with the same pattern, and the clear lines named",
          "[road][missing]") {
  Surface s = small_surface();
  CHECK(map_missing(s).cells == 0);
  CHECK(map_missing(s).clear_lines.size() == 1);
  s.height_m(4, 0) = s.height_m(5, 0) = s.height_m(12, 0) = kHole;  // line 0: two holes, x = 2 .. 6 m
  s.height_m(4, 1) = s.height_m(5, 1) = s.height_m(12, 1) = kHole;  // line 1: the same pattern
  s.height_m(20, 3) = kHole;                                        // line 3: one cell at the end
  const MissingMap map = map_missing(s);
  CHECK(map.cells == 7);
  CHECK(map.lines_with_missing == 3);
  CHECK(map.first_row == 4);
  CHECK(map.last_row == 20);
  REQUIRE(map.groups.size() == 2);
  CHECK(map.groups[0].line_begin == 0);
  CHECK(map.groups[0].line_end == 2);
  CHECK(map.groups[0].cells_per_line == 3);
  CHECK(map.groups[0].holes_per_line == 2);
  CHECK(map.groups[0].first_row == 4);
  CHECK(map.groups[0].last_row == 12);
  CHECK(map.groups[1].line_begin == 3);
  CHECK(map.groups[1].holes_per_line == 1);
  REQUIRE(map.clear_lines.size() == 2);
  CHECK(map.clear_lines[0] == std::pair<Eigen::Index, Eigen::Index>{2, 2});
  CHECK(map.clear_lines[1] == std::pair<Eigen::Index, Eigen::Index>{4, 4});

  const GridPositions grid{s.dx_m, s.y0_m, s.dy_m};
  CHECK(describe_map(map, grid, "  ") ==
        "  y = -0.5 .. -0.25 m (2 lines): 3 cells in 2 holes each, x = 2 .. 6 m\n"
        "  y = 0.25 m: 1 cell at x = 10 m\n"
        "  clear of holes: y = 0, 0.5 m\n");
  // Listing is capped; what is left out is counted.
  CHECK(describe_map(map, grid, "", 1) ==
        "y = -0.5 .. -0.25 m (2 lines): 3 cells in 2 holes each, x = 2 .. 6 m\n"
        "... and 1 more group of lines\n"
        "clear of holes: y = 0 m and 1 more ranges\n");
  const MissingMap capped = map_missing(s, 1);
  CHECK(capped.groups.size() == 1);
  CHECK(capped.groups_left_out == 1);
  CHECK(capped.cells == 7);

  const nlohmann::json j = to_json(map, grid);
  CHECK(j.at("cells") == 7);
  CHECK(j.at("groups")[0].at("y_to_m").get<double>() == -0.25);
  CHECK(j.at("groups")[0].at("x_to_m").get<double>() == 6.0);
  CHECK(j.at("clear_of_holes").size() == 2);
  CHECK(j.at("x_from_m").get<double>() == 2.0);

  // Spans, as the summary and the ERD refusal give them.
  CHECK(describe_span(find_missing(s, 0, 21, 3, 4), s) == "1 missing cell at x = 10 m");
  CHECK(describe_span(find_missing(s, 0, 21, 0, 2), s) == "6 missing cells between x = 2 and 6 m");
  CHECK(describe_span(find_missing(s, 0, 21, 2, 3), s) == "no missing cells");
}

TEST_CASE("the measured part is the unbroken lines, else the longest stretch clear of holes",
          "[road][missing]") {
  Surface s = small_surface();
  s.height_m(7, 1) = kHole;
  MeasuredPart part = measured_part(s);
  CHECK(part.whole_lines);
  CHECK(part.lines == std::vector<Eigen::Index>{0, 2, 3, 4});
  CHECK(part.row_begin == 0);
  CHECK(part.row_end == 21);

  // A gap across the whole width at rows 7 and 8: the longer piece (rows 9..20) is the part.
  s.height_m.row(8).setConstant(kHole);
  s.height_m.row(7).setConstant(kHole);
  part = measured_part(s);
  CHECK_FALSE(part.whole_lines);
  CHECK(part.row_begin == 9);
  CHECK(part.row_end == 21);
  CHECK(part.lines.size() == 5);
  const Surface piece = extract(s, part);
  CHECK(piece.samples() == 12);
  CHECK(piece.lines() == 5);
  CHECK(piece.height_m.allFinite());

  // Equal stretches (rows 0..9 and 11..20 either side of a gap at row 10): the first along x, with
  // the lines unbroken over it (line 2 has a hole in it at row 3, and its own longest run is the
  // second stretch).
  s = small_surface();
  s.height_m.row(10).setConstant(kHole);
  s.height_m(3, 2) = kHole;
  part = measured_part(s);
  CHECK(part.row_begin == 0);
  CHECK(part.row_end == 10);
  CHECK(part.lines == std::vector<Eigen::Index>{0, 1, 3, 4});
  s.height_m.setConstant(kHole);
  CHECK(measured_part(s).lines.empty());
}

TEST_CASE("a road cut across its width is still summarised: roughness of the longest measured stretch",
          "[road][missing][summary]") {
  Surface s = preset_surface("AS1");
  const SurfaceSummary whole = summarize(s);
  s.height_m.middleRows(1200, 10).setConstant(kHole);  // x = 60 .. 60.45 m, every line
  const SurfaceSummary cut = summarize(s);
  CHECK(cut.missing_cells == 1010);
  CHECK(cut.missing.groups.size() == 1);
  CHECK(cut.missing.clear_lines.empty());
  CHECK_FALSE(cut.psd_whole_lines);
  CHECK(cut.psd_lines == 101);
  CHECK(cut.psd_x_from_m == 0.0);
  CHECK(cut.psd_x_to_m == Approx(59.95));
  // The fit is exactly the one of the stretch x = 0 .. 59.95 m, in the band its length allows.
  Surface stretch = s;
  stretch.height_m = s.height_m.topRows(1200);
  CHECK(cut.psd_band_lo_cpm == Approx(4.0 / 59.95));
  const PsdFit direct = fit_psd(stretch, cut.psd_band_lo_cpm, cut.psd_band_hi_cpm);
  REQUIRE(cut.psd.bins > 0);
  CHECK(cut.psd.gd_n0_m3 == direct.gd_n0_m3);
  CHECK(cut.psd.waviness == direct.waviness);
  // The same road, 60 % of it: the level stays within the 35 % band of one surface's scatter
  // (road_summary_test), and the class is the whole road's.
  CHECK(cut.psd.gd_n0_m3 == Approx(whole.psd.gd_n0_m3).epsilon(0.35));
  CHECK(cut.roughness_class.label == whole.roughness_class.label);
  // Every lateral position crosses the gap: no IRI anywhere, each with the reason.
  CHECK(cut.iri_positions_measured == 0);
  for (const WheelPathRoughness& w : cut.wheel_paths) {
    CHECK(std::isnan(w.iri_m_per_km));
    CHECK(w.unavailable == "crosses 10 missing cells between x = 60 and 60.45 m");
  }
  const std::string text = to_text(cut);
  CHECK_THAT(text, Catch::Contains(
                       "on 101 of 101 lines over x = 0 .. 59.95 m (the longest stretch clear of holes)") &&
                       Catch::Contains("clear of holes: no line (every line has a missing cell)") &&
                       Catch::Contains("IRI         unavailable at all 11 lateral positions"));

  // Gaps every 0.5 m: the longest stretch, 0.4 m, puts the band's low end (4 / 0.4 m = 10
  // cycle/m) above its high end (5 cycle/m), so there is no fit.
  for (Eigen::Index i = 0; i < s.samples(); i += 10) s.height_m.row(i).setConstant(kHole);
  const SurfaceSummary chopped = summarize(s);
  CHECK(chopped.psd.bins == 0);
  CHECK(chopped.psd_lines == 101);
  CHECK_THAT(to_text(chopped), Catch::Contains("PSD fit     none (the longest stretch clear of holes, x = 0.05 .. "
                                               "0.45 m, is too short)"));

  s.height_m.setConstant(kHole);
  const SurfaceSummary nothing = summarize(s);
  CHECK(nothing.psd.bins == 0);
  CHECK(nothing.roughness_class.label.empty());
  CHECK_THAT(to_text(nothing), Catch::Contains("PSD fit     none (nothing measured)"));
}
