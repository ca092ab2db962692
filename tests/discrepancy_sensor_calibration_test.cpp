// Per-site sensor calibration fitted beside the fleet (discrepancy/sensor_calibration.hpp):
// the M-step finds a miscalibrated sensor, the EM recovers its gain and the sites' others,
// the result does not depend on the thread count, and bad options are refused.
#include <cmath>
#include <memory>

#include <catch2/catch.hpp>

#include "discrepancy/sensor_calibration.hpp"
#include "fleet/joint_sites.hpp"
#include "fleet/online_fit.hpp"
#include "fleet/replay.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

site::Site make_site(const char* road, double first_m, double spacing_m, int count) {
  site::SiteOptions o;
  o.sensors = {first_m, spacing_m, count};
  return site::Site(site::load_road(road), o);
}

// Two sites of the Table 1 fleet: north (AS1, 16 sensors) with sensor 5 reading 6 % high, south
// (AS2, 8 sensors at 2 m) reading 4 % low on every sensor. The records as logged, merged.
struct MiscalibratedSites {
  std::vector<std::unique_ptr<site::Site>> sites;
  std::vector<Eigen::VectorXd> truth;
  std::vector<records::WimRecord> records;
  explicit MiscalibratedSites(int n) {
    sites.push_back(std::make_unique<site::Site>(make_site("AS1", 76.0, 1.5, 16)));
    sites.push_back(std::make_unique<site::Site>(make_site("AS2", 70.0, 2.0, 8)));
    truth.push_back(Eigen::VectorXd::Ones(16));
    truth[0][4] = 1.06;
    truth.push_back(Eigen::VectorXd::Constant(8, 0.96));
    std::vector<std::vector<records::WimRecord>> per_site;
    for (std::size_t s = 0; s < sites.size(); ++s) {
      const site::Site& site = *sites[s];
      const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, n, site.lateral_min_m(), site.lateral_max_m(), 60 + s);
      auto log = fleet::simulate_log(site, trucks, 0.02, 70 + s).records;
      for (auto& r : log) r.impact_factor.array() *= truth[s].array();
      per_site.push_back(std::move(log));
    }
    records = fleet::merge_site_records(std::move(per_site));
  }
  std::vector<const site::Site*> pointers() const {
    return {sites[0].get(), sites[1].get()};
  }
  std::vector<Eigen::VectorXd> ones() const { return {Eigen::VectorXd::Ones(16), Eigen::VectorXd::Ones(8)}; }
  // A fit of the corrected records as fit --sites runs it (fewer particles).
  discrepancy::FitRecords fitter() const {
    return [this](const std::vector<records::WimRecord>& corrected) {
      fleet::OnlineFitOptions o;
      o.marginal.sampler.particles = 256;
      o.marginal.sampler.threads = 2;
      o.marginal.sampler.seed = 11;
      auto fit = fleet::make_online_fit(pointers(), o);
      fleet::ReplayOptions replay;
      replay.final_sweeps = o.default_final_sweeps();
      fleet::replay(*fit, corrected, replay);
      return fit;
    };
  }
};

}  // namespace

TEST_CASE("sensor calibration by Monte Carlo EM recovers a sensor's gain and a site's, within their standard errors",
          "[sensor_calibration][heavy]") {
  MiscalibratedSites s(80);
  discrepancy::CalibrationOptions o;
  o.draws.threads = 2;
  std::vector<discrepancy::CalibrationRound> seen;
  const auto done = discrepancy::fit_with_sensor_calibration(
      s.records, s.ones(), s.fitter(), o, [&](int, const discrepancy::CalibrationRound& r) { seen.push_back(r); });
  REQUIRE(done.rounds.size() == seen.size());
  INFO("rounds " << done.rounds.size() << ", last step " << done.rounds.back().largest_step_se << " se");
  CHECK(done.converged);
  // The first M-step sees the miscalibration far beyond its noise: the fit without calibration
  // leaves sensor 5 and the south site several standard errors off.
  CHECK(seen.front().largest_step_se > 10.0);
  CHECK(std::abs(seen.front().step[0].gain[4] - 1.0) > 5.0 * seen.front().step[0].se[4]);
  // Every gain within 4.5 standard errors of the truth (24 gains: a normal deviate beyond 4.5 has
  // probability 7e-6 each; the standard errors are Rubin's, which run about 7 % small over 20 such
  // networks (docs/sites.md), so 4.5 of them is 4.2 true ones, 3e-5 each).
  for (std::size_t site = 0; site < 2; ++site) {
    for (Eigen::Index j = 0; j < done.gains[site].size(); ++j) {
      INFO("site " << site << " sensor " << (j + 1) << ": " << done.gains[site][j] << " +- " << done.se[site][j]);
      CHECK(std::abs(done.gains[site][j] - s.truth[site][j]) < 4.5 * done.se[site][j]);
      // A gain is pinned to a few tenths of a percent by 80 trucks at σ_IF = 0.02.
      CHECK(done.se[site][j] < 0.006);
      CHECK(done.se[site][j] > 0.0005);
    }
  }
  // The last fit is on data with the fitted gains divided out.
  REQUIRE(done.fit != nullptr);
  CHECK(done.fit->core() == "marginal");
  CHECK(done.fit->trucks_seen() == 160);
}

TEST_CASE("the M-step's gains do not depend on the thread count, and bad options are refused", "[sensor_calibration][heavy]") {
  MiscalibratedSites s(30);
  const auto fit = s.fitter()(s.records);
  discrepancy::MarginalDrawOptions o{.draws = 6, .mh_steps = 4, .seed = 3, .threads = 1};
  const auto one = discrepancy::estimate_sensor_gains(*fit, o);
  o.threads = 2;
  const auto two = discrepancy::estimate_sensor_gains(*fit, o);
  REQUIRE(one.size() == 2);
  for (std::size_t site = 0; site < 2; ++site) {
    CHECK(one[site].gain == two[site].gain);
    CHECK(one[site].se == two[site].se);
    CHECK(one[site].trucks == 30);
  }
  o.draws = 1;
  CHECK_THROWS_AS(discrepancy::estimate_sensor_gains(*fit, o), UsageError);
  discrepancy::CalibrationOptions c;
  c.max_rounds = 0;
  CHECK_THROWS_AS(discrepancy::fit_with_sensor_calibration(s.records, s.ones(), s.fitter(), c), UsageError);
  c.max_rounds = 2;
  // Starting gains that do not fit a site's sensors.
  CHECK_THROWS_AS(discrepancy::fit_with_sensor_calibration(s.records, {Eigen::VectorXd::Ones(16)}, s.fitter(), c), UsageError);
}
