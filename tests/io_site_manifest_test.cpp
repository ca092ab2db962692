// The site manifest's reader: paths relative to the manifest's folder,
// and every bad manifest a DataError naming the manifest, the field and the site.
#include <chrono>
#include <fstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/site_manifest.hpp"
#include "test_support.hpp"

using namespace ssrfleet;

namespace {
struct ManifestDir {
  test::TempDir dir;
  std::string manifest = dir.file("sites/m.json");
  ManifestDir() {
    std::filesystem::create_directories(dir.file("sites/logs"));
    test::write_text(dir.file("sites/logs/a.csv"), "truck_id,speed_mps,sprung_mass_kg,if_1\n");
    test::write_text(dir.file("sites/road.csv"), "x\n");
    test::write_text(dir.file("b.csv"), "truck_id,speed_mps,sprung_mass_kg,if_1\n");
  }
  // A DataError from reading `text` as the manifest.
  DataError error(const std::string& text) const {
    test::write_text(manifest, text);
    const auto e = test::data_error([&] { io::read_site_manifest(manifest); });
    INFO(text);
    REQUIRE(e);
    CHECK(e->file() == manifest);
    return *e;
  }
};
}  // namespace

TEST_CASE("a site manifest resolves its paths against its own folder and keeps presets", "[io][sites]") {
  ManifestDir d;
  test::write_text(d.manifest, R"({"sites": [
      {"name": "north", "road": "road.csv", "sensors": "76,1.5,16", "log": "logs/a.csv"},
      {"name": "south.2", "road": "AS2", "sensors": "70,2,8", "log": ")" + d.dir.file("b.csv") + R"("}]})");
  const auto m = io::read_site_manifest(d.manifest);
  REQUIRE(m.sites.size() == 2u);
  CHECK(m.path == d.manifest);
  CHECK(m.sites[0].name == "north");
  CHECK(m.sites[0].road == d.dir.file("sites/road.csv"));
  CHECK(m.sites[0].log == d.dir.file("sites/logs/a.csv"));
  CHECK(m.sites[0].sensors == "76,1.5,16");
  CHECK(m.sites[1].road == "AS2");                  // a preset, not a file
  CHECK(m.sites[1].log == d.dir.file("b.csv"));     // absolute: as written
  CHECK(m.sites[1].index == 1u);
  CHECK(&m.find("south.2") == &m.sites[1]);
  try {
    m.find("east");
    FAIL("an unknown site was found");
  } catch (const UsageError& e) {
    CHECK(std::string(e.what()).find("north, south.2") != std::string::npos);  // the names it has
  }
}

TEST_CASE("a bad site manifest names the manifest, the field and the site", "[io][sites]") {
  ManifestDir d;
  const std::string good_site = R"({"name": "north", "road": "AS1", "sensors": "76,1.5,16", "log": "logs/a.csv"})";
  // A missing log file: the field, the site and the path it looked for.
  auto e = d.error(R"({"sites": [)" + good_site + R"(, {"name": "south", "road": "AS1", "sensors": "76,1.5,16", "log": "nowhere.csv"}]})");
  CHECK(e.field() == "sites[1].log");
  CHECK(e.reason().find("site 'south'") != std::string::npos);
  CHECK(e.reason().find(d.dir.file("sites/nowhere.csv")) != std::string::npos);
  // A missing road file.
  e = d.error(R"({"sites": [{"name": "n", "road": "gone.crg", "sensors": "76,1.5,16", "log": "logs/a.csv"}]})");
  CHECK(e.field() == "sites[0].road");
  CHECK(e.reason().find("site 'n'") != std::string::npos);
  // Unknown keys, at the top and in a site.
  e = d.error(R"({"sites": [)" + good_site + R"(], "network": "A"})");
  CHECK(e.field() == "network");
  e = d.error(R"({"sites": [{"name": "n", "road": "AS1", "sensors": "76,1.5,16", "log": "logs/a.csv", "lanes": 2}]})");
  CHECK(e.field() == "sites[0].lanes");
  CHECK(e.reason().find("site 'n'") != std::string::npos);
  CHECK(e.reason().find("name, road, sensors, log") != std::string::npos);
  // A missing key, a wrong type, an empty string.
  e = d.error(R"({"sites": [{"name": "n", "road": "AS1", "log": "logs/a.csv"}]})");
  CHECK(e.field() == "sites[0].sensors");
  CHECK(e.reason().find("missing") != std::string::npos);
  e = d.error(R"({"sites": [{"name": "n", "road": "AS1", "sensors": [76, 1.5, 16], "log": "logs/a.csv"}]})");
  CHECK(e.field() == "sites[0].sensors");
  e = d.error(R"({"sites": [{"name": "", "road": "AS1", "sensors": "76,1.5,16", "log": "logs/a.csv"}]})");
  CHECK(e.field() == "sites[0].name");
  // Names: the label rule, and unique.
  e = d.error(R"({"sites": [{"name": "a b", "road": "AS1", "sensors": "76,1.5,16", "log": "logs/a.csv"}]})");
  CHECK(e.field() == "sites[0].name");
  e = d.error(R"({"sites": [)" + good_site + "," + good_site + "]}");
  CHECK(e.field() == "sites[1].name");
  CHECK(e.reason().find("twice") != std::string::npos);
  // Not a manifest at all.
  CHECK(d.error(R"({"sites": []})").field() == "sites");
  CHECK(d.error(R"({})").field() == "sites");
  CHECK(d.error(R"([1, 2])").field() == "json");
  CHECK(d.error(R"({"sites": [)").field() == "json");
  CHECK(d.error(R"({"sites": [7]})").field() == "sites[0]");
  // No manifest.
  CHECK_THROWS_AS(io::read_site_manifest(d.dir.file("none.json")), MissingInputError);
}

TEST_CASE("a site manifest past its size limit is refused before it is parsed", "[io][sites]") {
  ManifestDir d;
  {
    // Valid JSON all the way (one site, then white space), so only the size can refuse it.
    std::ofstream out(d.manifest, std::ios::binary);
    out << R"({"sites": [{"name": "n", "road": "AS1", "sensors": "76,1.5,16", "log": "logs/a.csv"}])";
    const std::string spaces(1 << 20, ' ');
    for (std::uintmax_t written = 0; written <= io::kMaxSiteManifestBytes; written += spaces.size()) out << spaces;
    out << "}";
  }
  const auto start = std::chrono::steady_clock::now();
  const auto e = test::data_error([&] { io::read_site_manifest(d.manifest); });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  REQUIRE(e);
  CHECK(e->file() == d.manifest);
  CHECK(e->field() == "size");
  CHECK(seconds < 1.0);
}

TEST_CASE("a site's calibration is one gain per sensor in [0.5, 2], and a bad one is named down to the gain",
          "[io][sites]") {
  ManifestDir d;
  test::write_text(d.manifest, R"({"sites": [
      {"name": "north", "road": "AS1", "sensors": "76,1.5,4", "log": "logs/a.csv", "calibration": [1, 1.06, 0.5, 2]},
      {"name": "south", "road": "AS1", "sensors": "76,1.5,4", "log": "logs/a.csv"}]})");
  const io::SiteManifest m = io::read_site_manifest(d.manifest);
  CHECK(m.sites[0].calibration == std::vector<double>{1.0, 1.06, 0.5, 2.0});
  CHECK(m.sites[1].calibration.empty());
  const auto site_with = [](const std::string& calibration) {
    return R"({"sites": [{"name": "n", "road": "AS1", "sensors": "76,1.5,2", "log": "logs/a.csv", "calibration": )" +
           calibration + "}]}";
  };
  for (const char* bad : {"[]", "1.02", "{\"1\": 1.0}"}) {
    const DataError e = d.error(site_with(bad));
    CHECK(e.field() == "sites[0].calibration");
    CHECK(e.reason().find("site 'n'") != std::string::npos);
  }
  for (const char* bad : {"[1, 0.49]", "[1, 2.01]", "[1, \"1\"]", "[1, null]", "[1, -1]"}) {
    const DataError e = d.error(site_with(bad));
    INFO(bad);
    CHECK(e.field() == "sites[0].calibration[1]");
    CHECK(e.reason().find("[0.5, 2]") != std::string::npos);
    CHECK(e.reason().find("sensor 2") != std::string::npos);
  }
}
