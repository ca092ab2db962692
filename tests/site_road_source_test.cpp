// Where `--road` comes from (site/road_source.hpp) and what a site makes of missing road: an
// OpenCRG file stands in for a preset, its warnings reach the caller's stream, an ERD file is
// refused for a surface, and a site refuses a trucks' stretch that crosses missing cells while
// allowing them past the last sensor.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "road/crg_writer.hpp"
#include "road/erd_format.hpp"
#include "road/surface_presets.hpp"
#include "road/wheel_path.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "test_support.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

TEST_CASE("an OpenCRG path loads as the surface it holds and its warnings reach the caller", "[road][site]") {
  test::TempDir dir;
  const std::string path = dir.file("as1.crg");
  road::Surface s = road::preset_surface("AS1");
  s.height_m(1990, 100) = std::numeric_limits<double>::quiet_NaN();
  road::write_crg_file(s, path);
  std::ostringstream warnings;
  const road::Surface back = site::load_road(path, &warnings);
  CHECK(back.name == path);
  CHECK((back.height_m.col(3) == s.height_m.col(3)).all());
  CHECK_THAT(warnings.str(), Catch::Contains("warning: road '" + path + "': 1 missing cells"));
  CHECK_NOTHROW(site::load_road(path));  // no stream: silent

  const std::string erd = dir.file("paths.erd");
  road::write_erd_file(road::wheel_path_profiles(s, {1.0}), erd);
  CHECK_THROWS_WITH(site::load_road(erd), Catch::Contains("ERD file of longitudinal profiles"));
  CHECK_THROWS_AS(site::load_road(erd), UsageError);
}

TEST_CASE("a site refuses missing cells in the trucks' stretch and allows them past the last sensor",
          "[road][site]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  road::Surface beyond = road::preset_surface("AS1");
  beyond.height_m.block(1980, 0, 21, 3).setConstant(nan);  // x = 99 .. 100 m, right edge
  const site::Site ok(beyond, site::SiteOptions{});        // last sensor at 98.5 m
  site::TruckBatch trucks;
  trucks.resize(1);
  trucks.speed_mps << 22.0;
  trucks.sprung_mass_kg << 4500.0;
  trucks.stiffness_npm << 5e5;
  trucks.tyre_stiffness_npm << 2e6;
  trucks.lateral_m << 0.02;
  Eigen::ArrayXXd if_out(ok.sensors(), 1);
  ok.impact_factors(trucks, if_out);
  CHECK(if_out.allFinite());
  // Predicting further along the road would read the hole.
  const vehicle::PassIntegrator further(ok.surface().dx_m, ok.surface().samples(), {50.0, 99.5});
  Eigen::ArrayXXd further_out(2, 1);
  CHECK_THROWS_AS(ok.impact_factors_at(further, trucks, further_out), DataError);

  road::Surface inside = road::preset_surface("AS1");
  inside.name = "holed";
  inside.height_m(1200, 100) = nan;  // x = 60 m, the left edge (y = 5 m)
  try {
    const site::Site refused(inside, site::SiteOptions{});
    FAIL("a site over missing road was built");
  } catch (const DataError& e) {
    CHECK(e.file() == "holed");
    CHECK_THAT(e.what(), Catch::Contains("x = 0 to 98.5 m") &&
                             Catch::Contains("1 missing cell, the first at x = 60 m, y = 5 m"));
  }
}
