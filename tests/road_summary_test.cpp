// The surface summary: geometry, PSD fit, IRI across the road, in text and JSON.
#include <catch2/catch.hpp>

#include <string>

#include "road/iri.hpp"
#include "road/surface_presets.hpp"
#include "road/surface_summary.hpp"
#include "road/wheel_path.hpp"

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
  CHECK(sum.iri_by_position.back().first == Approx(5.0));
  CHECK(sum.iri_by_position[3].second == iri_m_per_km(wheel_path(s, 1.5), s.dx_m));
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
