// The absorbed trucks' data (fleet/absorbed_trucks.hpp) read back exactly, in memory or spilled,
// for trucks of sites with different sensor counts.
#include <random>

#include <catch2/catch.hpp>

#include "fleet/absorbed_trucks.hpp"
#include "test_support.hpp"

using namespace ssrfleet;

TEST_CASE("absorbed trucks read back exactly, in memory and in spill files, over sites of 16 and 3 sensors",
          "[spill]") {
  test::TempDir dir;
  fleet::AbsorbedTrucks memory, spilled(dir.path().string());
  std::mt19937_64 g(5);
  std::normal_distribution<double> noise(1.0, 0.1);
  struct Truck {
    double speed, mass;
    std::uint32_t site;
    Eigen::VectorXd y;
    model::TruckFit fit;
  };
  std::vector<Truck> trucks;
  for (int i = 0; i < 5000; ++i) {
    Truck t;
    t.site = static_cast<std::uint32_t>(g() % 2);
    t.speed = 20.0 + noise(g);
    t.mass = 14000.0 * noise(g);
    t.y = Eigen::VectorXd::NullaryExpr(t.site == 0 ? 16 : 3, [&] { return noise(g); });
    t.fit.stiffness_npm = 5e5 * noise(g);
    t.fit.lateral_m = noise(g) - 1.0;
    t.fit.passes = i;
    memory.push_back(t.speed, t.mass, t.site, t.y, t.fit);
    spilled.push_back(t.speed, t.mass, t.site, t.y, t.fit);
    trucks.push_back(std::move(t));
  }
  REQUIRE(spilled.size() == trucks.size());
  REQUIRE(memory.size() == trucks.size());
  for (std::size_t i = 0; i < trucks.size(); ++i) {
    const Truck& t = trucks[i];
    for (const fleet::AbsorbedTrucks* a : {&memory, &spilled}) {
      const bool same = a->speed_mps(i) == t.speed && a->sprung_mass_kg(i) == t.mass && a->site(i) == t.site &&
                        a->impact_factors(i).size() == t.y.size() && a->impact_factors(i) == t.y &&
                        a->fit(i).stiffness_npm == t.fit.stiffness_npm && a->fit(i).lateral_m == t.fit.lateral_m &&
                        a->fit(i).passes == t.fit.passes;
      REQUIRE(same);
    }
  }
  spilled.clear();
  CHECK(spilled.empty());
  spilled.push_back(1.0, 2.0, 1, Eigen::VectorXd::Constant(3, 0.5), model::TruckFit{});
  CHECK(spilled.impact_factors(0) == Eigen::VectorXd::Constant(3, 0.5));
}
