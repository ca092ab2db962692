// serve over a stream of vehicle classes and over a joint stream of two sites: the page's class and
// site selectors get the class's or the site's own SSR, equal to what predict --class / --site
// computes from the same state, and the history of a class starts at its first truck.
#include <chrono>
#include <sstream>
#include <thread>

#include <catch2/catch.hpp>

#include "io/site_manifest.hpp"
#include "serve/server.hpp"
#include "serve_client.hpp"
#include "site/road_source.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::http_get;

namespace {

struct Running {
  std::unique_ptr<serve::Server> server;
  std::thread thread;
  int port = 0;
  explicit Running(serve::StateConfig config) {
    serve::ServeOptions options;
    options.port = 0;
    server = std::make_unique<serve::Server>(std::vector<serve::StateConfig>{std::move(config)}, options);
    port = server->bind();
    thread = std::thread([this] { server->run(); });
  }
  ~Running() {
    server->stop();
    thread.join();
  }
};

test::HttpReply computed(int port, const std::string& target) {
  test::HttpReply r;
  for (int i = 0; i < 600 && (r = http_get(port, target)).status == 202; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return r;
}

// The first data row of predict's CSV.
std::vector<double> first_row(const std::string& csv) {
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  std::vector<double> row;
  std::istringstream cells(line);
  for (std::string cell; std::getline(cells, cell, ',');) row.push_back(std::stod(cell));
  return row;
}

}  // namespace

TEST_CASE("serve: a class alone and a site of a joint stream, as predict computes them", "[serve][heavy]") {
  test::TempDir dir;
  SECTION("vehicle classes") {
    REQUIRE(test::run_ssrfleet("simulate --trucks 30 --seed 3 --fleet-mix 'A:share=0.6,k-mean=400e3;B:share=0.4,"
                               "k-mean=600e3' --out '" + dir.file("log.csv") + "'", dir).status == 0);
    REQUIRE(test::run_ssrfleet("stream --state '" + dir.file("st") + "' --input '" + dir.file("log.csv") +
                                   "' --particles 128 --quiet", dir).status == 0);
    site::Site site(site::load_road("AS1", nullptr), site::SiteOptions{});
    Running s({"st", dir.file("st"), {{"", &site}}});
    const auto summary = http_get(s.port, "/api/summary").json();
    CHECK(summary["classes"] == nlohmann::json({"A", "B"}));
    CHECK(summary["hyperparameters"].size() == 14);
    const auto b = http_get(s.port, "/api/history?class=B&param=K").json();
    const auto& trucks = b["series"][0]["trucks"];
    REQUIRE(trucks.size() >= 2);
    CHECK(trucks.front().get<int>() > 1);  // the first record is of class A (seed 3): B starts later
    CHECK(trucks.back() == 30);
    const auto a = computed(s.port, "/api/ssr?class=A");
    REQUIRE(a.status == 200);
    const auto predict = test::run_ssrfleet("predict --posterior '" + dir.file("st") + "' --class A", dir);
    REQUIRE(predict.status == 0);
    const auto row = first_row(predict.out);
    CHECK(a.json()["ssr"]["mean_if"][0].get<double>() == Approx(row[1]).epsilon(1e-9));
    CHECK(a.json()["ssr"]["lower95"][0].get<double>() == Approx(row[2]).epsilon(1e-9));
    CHECK(http_get(s.port, "/api/ssr?class=C").json()["parameter"] == "class");
  }
  SECTION("a joint stream of two sites") {
    const std::string examples = std::string(SSRFLEET_SOURCE_DIR) + "/examples";
    // Alternate records of the two example sites, south's eight missing columns empty.
    const auto rows = [&](const std::string& name) {
      std::istringstream in(test::read_text(examples + "/site-" + name + ".csv"));
      std::vector<std::string> out;
      for (std::string line; std::getline(in, line);) {
        if (!line.empty() && line[0] != '#') out.push_back(line);
      }
      return out;
    };
    const auto north = rows("north"), south = rows("south");
    std::string log = "site," + north[0] + "\n";
    for (std::size_t i = 1; i <= 12; ++i) log += "north," + north[i] + "\nsouth," + south[i] + ",,,,,,,,\n";
    test::write_text(dir.file("all.csv"), log);
    const std::string manifest = examples + "/sites.json";
    REQUIRE(test::run_ssrfleet("stream --sites '" + manifest + "' --state '" + dir.file("net") + "' --input '" +
                                   dir.file("all.csv") + "' --particles 128 --quiet", dir).status == 0);
    const io::SiteManifest m = io::read_site_manifest(manifest);
    std::vector<std::unique_ptr<site::Site>> sites;
    std::vector<serve::ServedSite> served;
    for (const auto& entry : m.sites) {
      // The manifest's "FIRST_M,SPACING_M,COUNT", as the command reads it.
      site::SiteOptions o;
      char comma = ',';
      std::istringstream(entry.sensors) >> o.sensors.first_m >> comma >> o.sensors.spacing_m >> comma >>
          o.sensors.count;
      sites.push_back(std::make_unique<site::Site>(site::load_road(entry.road, nullptr), o));
      served.push_back({entry.name, sites.back().get()});
    }
    Running s({"net", dir.file("net"), served});
    CHECK(http_get(s.port, "/api/summary").json()["sites"] == nlohmann::json({"north", "south"}));
    CHECK(http_get(s.port, "/api/ssr").json()["ssr"]["position_m"].size() == 16);  // the first site's sensors
    const auto south_ssr = computed(s.port, "/api/ssr?site=south");
    REQUIRE(south_ssr.status == 200);
    CHECK(south_ssr.json()["ssr"]["position_m"].size() == 8);
    const auto predict = test::run_ssrfleet("predict --posterior '" + dir.file("net") + "' --sites '" + manifest +
                                                "' --site south", dir);
    REQUIRE(predict.status == 0);
    const auto row = first_row(predict.out);
    CHECK(south_ssr.json()["ssr"]["position_m"][0].get<double>() == row[0]);
    CHECK(south_ssr.json()["ssr"]["mean_if"][0].get<double>() == Approx(row[1]).epsilon(1e-9));
    CHECK(http_get(s.port, "/api/ssr?site=east").json()["parameter"] == "site");
  }
}
