// The force log that weigh reads: sprung mass optional, and every bad
// input a DataError naming file, line and field.
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/damage_csv.hpp"
#include "io/force_log.hpp"
#include "io/static_weights_csv.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {
std::vector<records::ForceRecord> read(const std::string& text, int expected_sensors = 0) {
  std::istringstream in(text);
  return io::read_force_log(in, "forces.csv", expected_sensors, "(--sensors 76,1.5,2)");
}

// The DataError reading `text` throws: checks its line and field, returns its message.
std::string error_of(const std::string& text, std::size_t line, const std::string& field, int expected_sensors = 0) {
  try {
    read(text, expected_sensors);
  } catch (const DataError& e) {
    CHECK(e.file() == "forces.csv");
    CHECK(e.line() == line);
    CHECK(e.field() == field);
    return e.what();
  }
  FAIL("no DataError for:\n" << text);
  return "";
}
}  // namespace

TEST_CASE("a force log reads with or without the sprung mass and round-trips", "[io]") {
  const auto without = read("# comment\ntruck_id,speed_mps,force_1,force_2\nA,20,45000,46000.5\nB,22.5,40000,0\n", 2);
  REQUIRE(without.size() == 2);
  CHECK(without[0].truck_id == "A");
  CHECK(without[0].line == 3);
  CHECK_FALSE(without[0].sprung_mass_kg.has_value());
  CHECK(without[0].force_n[1] == 46000.5);
  CHECK(without[1].force_n[1] == 0.0);  // a wheel in the air reads 0: allowed
  const auto with = read("truck_id,sprung_mass_kg,speed_mps,force_2,force_1,extra\nA,4400,20,2,1,x\n");
  REQUIRE(with.size() == 1);
  CHECK(with[0].sprung_mass_kg.value() == 4400.0);
  CHECK(with[0].force_n[0] == 1.0);  // columns in any order
  CHECK(with[0].force_n[1] == 2.0);

  for (bool mass : {false, true}) {
    std::ostringstream out;
    io::write_force_log(out, with, mass);
    const auto back = read(out.str(), 2);
    REQUIRE(back.size() == 1);
    CHECK(back[0].force_n == with[0].force_n);
    CHECK(back[0].sprung_mass_kg.has_value() == mass);
  }
}

TEST_CASE("bad force logs are data errors naming file, line and field", "[io]") {
  SECTION("a negative force") {
    const auto m = error_of("truck_id,speed_mps,force_1,force_2\nA,20,45000,-3\n", 2, "force_2");
    CHECK(m.find("forces.csv:2: field 'force_2'") != std::string::npos);
    CHECK(m.find("negative") != std::string::npos);
  }
  SECTION("a force that is not a number") {
    const auto m = error_of("truck_id,speed_mps,force_1,force_2\nA,20,45000,46000\nB,20,heavy,46000\n", 3, "force_1");
    CHECK(m.find("'heavy' is not a number") != std::string::npos);
  }
  SECTION("a NaN or empty force") {
    error_of("truck_id,speed_mps,force_1\nA,20,nan\n", 2, "force_1");
    error_of("truck_id,speed_mps,force_1\nA,20,\n", 2, "force_1");
  }
  SECTION("a missing column") {
    CHECK(error_of("truck_id,force_1\nA,45000\n", 1, "speed_mps").find("missing") != std::string::npos);
    error_of("# a comment first\nspeed_mps,force_1\n20,45000\n", 2, "truck_id");
    CHECK(error_of("truck_id,speed_mps\nA,20\n", 1, "force_1").find("force_1..force_M") != std::string::npos);
  }
  SECTION("impact factors where forces are needed") {
    CHECK(error_of("truck_id,speed_mps,if_1\nA,20,1.01\n", 1, "force_1").find("impact factors") != std::string::npos);
  }
  SECTION("a sensor count other than the site's names the first missing or extra column") {
    const auto few = error_of("truck_id,speed_mps,force_1\nA,20,45000\n", 1, "force_2", 2);
    CHECK(few.find("1 force columns but the posterior's site has 2 sensors (--sensors 76,1.5,2)") != std::string::npos);
    error_of("truck_id,speed_mps,force_1,force_2,force_3\nA,20,1,2,3\n", 1, "force_3", 2);
  }
  SECTION("a short row, a duplicate id, an impossible speed, all forces zero") {
    error_of("truck_id,speed_mps,force_1,force_2\nA,20,45000\n", 2, "columns");
    error_of("truck_id,speed_mps,force_1\nA,20,45000\nA,21,45000\n", 3, "truck_id");
    error_of("truck_id,speed_mps,force_1\nA,200,45000\n", 2, "speed_mps");
    error_of("truck_id,speed_mps,force_1,force_2\nA,20,0,0\n", 2, "force_1");
  }
  SECTION("no records") { error_of("truck_id,speed_mps,force_1\n", 2, "truck_id"); }
}

TEST_CASE("the damage and weights CSVs have exactly the issue's headers", "[io]") {
  records::DamageProfile p;
  p.position_m = {76.0};
  p.dlc = {0.05};
  p.hot_spot = {true};
  for (double n : {1.0, 4.0, 2.5}) p.powers.push_back({n, {1.0}, {0.9}, {1.1}});
  std::ostringstream out;
  io::write_damage_csv(out, p);
  CHECK(out.str() ==
        "position_m,dlc,a1,a1_q025,a1_q975,a4,a4_q025,a4_q975,a2.5,a2.5_q025,a2.5_q975,hot_spot\n"
        "76,0.05,1,0.9,1.1,1,0.9,1.1,1,0.9,1.1,1\n");
  std::ostringstream w;
  io::write_static_weights_csv(w, {{"T1", 45.5, 45.0, 46.0, 45.2, 3}});
  CHECK(w.str() == "truck_id,static_kn,static_kn_q025,static_kn_q975\nT1,45.5,45,46\n");
}
