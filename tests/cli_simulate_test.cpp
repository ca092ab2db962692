#include <filesystem>

#include <catch2/catch.hpp>

#include "io/wim_log.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

TEST_CASE("ssrfleet simulate writes a WIM log that reads back with one record per truck", "[cli]") {
  test::TempDir dir;
  const auto r = run_ssrfleet("simulate --road AS1 --trucks 12 --seed 5 --out '" + dir.file("log.csv") +
                                  "' --truth '" + dir.file("truth.csv") + "'",
                              dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  int sensors = 0;
  const auto records = io::read_wim_log_file(dir.file("log.csv"), 420.0, &sensors);
  CHECK(records.size() == 12);
  CHECK(sensors == 16);
  // The same seed gives the same log; --noise 0 gives a different (exact) one.
  const auto again = run_ssrfleet("simulate --trucks 12 --seed 5 --quiet --out -", dir);
  REQUIRE(again.status == 0);
  CHECK(again.out == test::read_text(dir.file("log.csv")));
  // A truck list round trip: simulating the written truth reproduces the log exactly.
  const auto from_list = run_ssrfleet("simulate --trucks '" + dir.file("truth.csv") + "' --seed 5 --quiet", dir);
  REQUIRE(from_list.status == 0);
  CHECK(from_list.out.substr(from_list.out.find('\n')) ==
        test::read_text(dir.file("log.csv")).substr(test::read_text(dir.file("log.csv")).find('\n')));
}

TEST_CASE("ssrfleet simulate refuses bad input with file line and field and leaves no output", "[cli]") {
  test::TempDir dir;
  const std::string out = dir.file("out.csv");
  const std::string header = "truck_id,speed_mps,sprung_mass_kg,k_npm,kt_npm,z_m\n";
  struct Case {
    const char* name;
    std::string truck_list;
    std::string expect;  // in stderr
  };
  const std::vector<Case> cases = {
      {"ragged", header + "A,23,4450,5e5,1.95e6,1.5\nB,23,4450,5e5\n", ":3: field 'columns'"},
      {"non-numeric", header + "A,fast,4450,5e5,1.95e6,1.5\n", ":2: field 'speed_mps'"},
      {"nan", header + "A,23,4450,nan,1.95e6,1.5\n", ":2: field 'k_npm'"},
      {"missing column", "truck_id,speed_mps,sprung_mass_kg,k_npm,z_m\nA,23,4450,5e5,1.5\n", "field 'kt_npm'"},
      {"duplicate id", header + "A,23,4450,5e5,1.95e6,1.5\nA,23,4450,5e5,1.95e6,1.5\n", ":3: field 'truck_id'"},
      {"negative speed", header + "A,-23,4450,5e5,1.95e6,1.5\n", ":2: field 'speed_mps'"},
      {"zero mass", header + "A,23,0,5e5,1.95e6,1.5\n", ":2: field 'sprung_mass_kg'"},
      {"negative stiffness", header + "A,23,4450,-5e5,1.95e6,1.5\n", ":2: field 'k_npm'"},
      {"z off the road", header + "A,23,4450,5e5,1.95e6,7.5\n", ":2: field 'z_m'"},
  };
  for (const auto& c : cases) {
    INFO(c.name);
    const std::string list = dir.file("trucks.csv");
    test::write_text(list, c.truck_list);
    const auto r = run_ssrfleet("simulate --trucks '" + list + "' --out '" + out + "'", dir);
    CHECK(r.status == 65);
    CHECK(r.err.find(list) != std::string::npos);
    CHECK(r.err.find(c.expect) != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a missing file is exit 66") {
    const auto r = run_ssrfleet("simulate --trucks '" + dir.file("nope.csv") + "' --out '" + out + "'", dir);
    CHECK(r.status == 66);
    CHECK(r.err.find("nope.csv") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a sensor beyond the road's end is a usage error") {
    const auto r = run_ssrfleet("simulate --sensors 76,1.5,30 --out '" + out + "'", dir);
    CHECK(r.status == 64);
    CHECK(r.err.find("beyond the road's end") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  SECTION("a seed that is not a number is a usage error") {
    const auto r = run_ssrfleet("simulate --seed abc --out '" + out + "'", dir);
    CHECK(r.status == 64);
    CHECK(r.err.find("--seed") != std::string::npos);
  }
  SECTION("an unknown preset or missing road file is refused") {
    const auto r = run_ssrfleet("simulate --road '" + dir.file("road.csv") + "' --out '" + out + "'", dir);
    CHECK(r.status == 66);
    CHECK_FALSE(std::filesystem::exists(out));
  }
}

TEST_CASE("simulate --model switches on several effects at once and needs every parameter", "[cli][extension]") {
  test::TempDir dir;
  const auto one = run_ssrfleet("simulate --trucks 5 --seed 2 --noise 0 --quiet --model speed_bias:factor=1.1 --out '" +
                                     dir.file("one.csv") + "'", dir);
  const auto two = run_ssrfleet("simulate --trucks 5 --seed 2 --noise 0 --quiet --out '" + dir.file("two.csv") +
                                     "' --model speed_bias:factor=1.1+sensor_gain:sensor=4,gain=1.05", dir);
  INFO(two.err);
  REQUIRE(one.status == 0);
  REQUIRE(two.status == 0);
  CHECK(test::read_text(dir.file("two.csv")).find("model speed_bias:factor=1.1+sensor_gain:sensor=4,gain=1.05") !=
        std::string::npos);
  // Sensor 4 reads 1.05 times what it reads with the speed bias alone; the others the same.
  const auto a = io::read_wim_log_file(dir.file("one.csv"), 420.0), b = io::read_wim_log_file(dir.file("two.csv"), 420.0);
  REQUIRE(a.size() == 5);
  REQUIRE(b.size() == 5);
  for (std::size_t t = 0; t < a.size(); ++t) {
    for (Eigen::Index s = 0; s < a[t].impact_factor.size(); ++s) {
      CHECK(b[t].impact_factor[s] == Approx(a[t].impact_factor[s] * (s == 3 ? 1.05 : 1.0)).epsilon(1e-8));
    }
  }
  const auto missing = run_ssrfleet("simulate --trucks 5 --quiet --model speed_bias+sensor_gain:sensor=4", dir);
  CHECK(missing.status != 0);
  CHECK(missing.err.find("missing: speed_bias.factor, sensor_gain.gain") != std::string::npos);
}
