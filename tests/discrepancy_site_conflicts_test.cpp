// Which site's fleet differs (discrepancy/site_conflicts.hpp): five simulated
// sites, one of them carrying another fleet, and the same five with one fleet.
#include <cmath>
#include <memory>

#include <catch2/catch.hpp>

#include "discrepancy/site_conflicts.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

// The first `count` of five sites on the three preset roads and four sensor arrays, `trucks` trucks
// each; `odd` (if below count) carries a fleet whose trucks are stiffer: K = 580 kN/m and
// K_t = 2,150 kN/m against Table 1's 500 and 1,950 (1.6 and 1.0 fleet sd apart: another operator's
// vehicles).
struct FiveSites {
  std::vector<std::unique_ptr<site::Site>> sites;
  std::vector<std::vector<records::WimRecord>> logs;
  explicit FiveSites(std::size_t odd, std::size_t count = 5, int trucks = 60) {
    struct Spec {
      const char* road;
      double first, spacing;
      int count;
    };
    const Spec specs[5] = {{"AS1", 76, 1.5, 16}, {"AS2", 70, 2, 8}, {"AS3", 60, 1.5, 12}, {"AS1", 40, 2, 10}, {"AS2", 20, 1.5, 16}};
    for (std::size_t s = 0; s < count; ++s) {
      site::SiteOptions o;
      o.sensors = {specs[s].first, specs[s].spacing, specs[s].count};
      sites.push_back(std::make_unique<site::Site>(site::load_road(specs[s].road), o));
      fleet::FleetDistribution fleet;
      if (s == odd) {
        fleet.stiffness_npm.mean = 580e3;
        fleet.tyre_stiffness_npm.mean = 2150e3;
      }
      const auto drawn = fleet::draw_fleet(fleet, trucks, sites[s]->lateral_min_m(), sites[s]->lateral_max_m(), 70 + s);
      logs.push_back(fleet::simulate_log(*sites[s], drawn, 0.02, 80 + s).records);
    }
  }
  std::vector<const site::Site*> pointers() const {
    std::vector<const site::Site*> p;
    for (const auto& s : sites) p.push_back(s.get());
    return p;
  }
};

discrepancy::SiteConflictOptions options() {
  discrepancy::SiteConflictOptions o;
  o.fit.marginal.sampler.particles = 256;
  o.fit.marginal.sampler.threads = 2;
  o.fit.marginal.sampler.seed = 11;
  return o;
}

}  // namespace

TEST_CASE("the site check's reference tail is the chi-square with 4 degrees of freedom", "[sites][conflict]") {
  CHECK(discrepancy::chi2_4_tail(0.0) == 1.0);
  // Quantiles of χ²_4 (Abramowitz & Stegun, table 26.8): 0.95 at 9.487729, 0.99 at 13.276704,
  // 0.999 at 18.466827.
  CHECK(discrepancy::chi2_4_tail(9.487729) == Approx(0.05).epsilon(1e-6));
  CHECK(discrepancy::chi2_4_tail(13.276704) == Approx(0.01).epsilon(1e-6));
  CHECK(discrepancy::chi2_4_tail(18.466827) == Approx(0.001).epsilon(1e-5));
}

TEST_CASE("of three sites, the one whose fleet differs is named, and none of three sites of one fleet is",
          "[sites][conflict][heavy]") {
  // 40 trucks a site. The odd site is named in the first round, against the two others; those two
  // are then checked against each other and agree.
  {
    FiveSites c(1, 3, 40);
    const auto result = discrepancy::check_site_conflicts(c.pointers(), c.logs, options());
    REQUIRE(result.size() == 3);
    for (const auto& r : result) {
      INFO("site " << r.site << ": D2 " << r.distance2 << ", p " << r.p_value);
      CHECK(r.flagged == (r.site == 1));
      CHECK_FALSE(r.undecided);
      CHECK(r.round == (r.site == 1 ? 1 : 2));
      CHECK(r.compared_with == (r.site == 1 ? 2u : 1u));
    }
  }
  FiveSites c(3, 3, 40);
  for (const auto& r : discrepancy::check_site_conflicts(c.pointers(), c.logs, options())) {
    INFO("site " << r.site << ": D2 " << r.distance2 << ", p " << r.p_value);
    CHECK_FALSE(r.flagged);
  }
}

// Long: 40 fits (146 s on 2 cores). Five sites take the rounds: the odd site named first, the four
// others checked again without it.
TEST_CASE("of five sites, the one whose fleet differs is named, and none of five sites of one fleet is",
          "[sites][conflict][long]") {
  {
    FiveSites c(2);
    const auto result = discrepancy::check_site_conflicts(c.pointers(), c.logs, options());
    REQUIRE(result.size() == 5);
    for (const auto& r : result) {
      INFO("site " << r.site << ": D2 " << r.distance2 << ", p " << r.p_value << ", round " << r.round << ", K alone "
                   << r.alone_mean[0] << " others " << r.rest_mean[0]);
      CHECK(r.flagged == (r.site == 2));
      CHECK(r.trucks == 60);
    }
    // Named in the first round, against the four others; the others checked again without it.
    CHECK(result[2].round == 1);
    CHECK(result[2].compared_with == 4);
    CHECK(result[0].round == 2);
    CHECK(result[0].compared_with == 3);
    CHECK(result[2].alone_mean[0] > result[2].rest_mean[0] + 3.0 * result[2].alone_sd[0]);
  }
  {
    FiveSites c(5);  // one fleet everywhere
    const auto result = discrepancy::check_site_conflicts(c.pointers(), c.logs, options());
    for (const auto& r : result) {
      INFO("site " << r.site << ": D2 " << r.distance2 << ", p " << r.p_value);
      CHECK_FALSE(r.flagged);
      CHECK(r.round == 1);
    }
  }
}

TEST_CASE("two sites that conflict are both marked undecided and neither is named", "[sites][conflict][heavy]") {
  FiveSites c(1, 2, 40);
  const auto result = discrepancy::check_site_conflicts(c.pointers(), c.logs, options());
  REQUIRE(result.size() == 2);
  for (const auto& r : result) {
    INFO("site " << r.site << ": D2 " << r.distance2 << ", p " << r.p_value);
    CHECK(r.undecided);
    CHECK_FALSE(r.flagged);
    CHECK(r.p_value < 0.01 / 2);
  }
}

TEST_CASE("the site check refuses a single site, a site without records and an alpha outside (0, 1)",
          "[sites][conflict]") {
  FiveSites c(5);
  auto o = options();
  CHECK_THROWS_AS(discrepancy::check_site_conflicts({c.sites[0].get()}, {c.logs[0]}, o), UsageError);
  CHECK_THROWS_AS(discrepancy::check_site_conflicts({c.sites[0].get(), c.sites[1].get()}, {c.logs[0], {}}, o), UsageError);
  o.alpha = 1.5;
  CHECK_THROWS_AS(discrepancy::check_site_conflicts({c.sites[0].get(), c.sites[1].get()}, {c.logs[0], c.logs[1]}, o),
                  UsageError);
}
