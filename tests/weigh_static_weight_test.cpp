// The SSR-corrected static-weight estimator: the combination's algebra, the
// fixed point over the unknown sprung mass, and on simulated trucks an unbiased estimate whose
// 95 % intervals cover the truth as often as they say.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "records/force_record.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "vehicle/quarter_car.hpp"
#include "util/errors.hpp"
#include "weigh/static_weight.hpp"

using namespace ssrfleet;

namespace {
// The posterior as a point mass at the generating fleet (Table 1, σ_IF 0.02): what the estimator
// does when θ is known. Its observed traffic is unused (weigh fixes the traffic to the truck).
fleet::PosteriorCloud point_mass(const fleet::FleetDistribution& d, double sigma_if) {
  fleet::PosteriorCloud cloud;
  cloud.method = "smc";
  Eigen::VectorXd th(fleet::kHyperCount);
  th << d.stiffness_npm.mean, d.stiffness_npm.sd, d.tyre_stiffness_npm.mean, d.tyre_stiffness_npm.sd, d.lateral_m.mean,
      d.lateral_m.sd, sigma_if;
  cloud.theta = th.replicate(1, 4);
  cloud.weights = Eigen::ArrayXd::Constant(4, 0.25);
  cloud.speed_mps = {d.speed_mps.mean};
  cloud.sprung_mass_kg = {d.sprung_mass_kg.mean};
  return cloud;
}

// Simulated trucks as the force sensors log them, with their true static wheel loads.
struct ForceLog {
  std::vector<records::ForceRecord> records;
  std::vector<double> static_n;
};
ForceLog simulate_forces(const site::Site& site, int trucks, double sigma_if, std::uint64_t seed) {
  const auto drawn = fleet::draw_fleet(fleet::FleetDistribution{}, trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  const auto log = fleet::simulate_log(site, drawn, sigma_if, seed);
  ForceLog out;
  for (const auto& r : log.records) {
    const double p_s = (r.sprung_mass_kg + site.options().unsprung_mass_kg) * vehicle::gravity_mps2;
    records::ForceRecord f;
    f.truck_id = r.truck_id;
    f.speed_mps = r.speed_mps;
    f.force_n = r.impact_factor * p_s;
    f.line = r.line;
    out.records.push_back(f);
    out.static_n.push_back(p_s);
  }
  return out;
}
}  // namespace

TEST_CASE("the combination is unbiased for forces on the predicted pattern and weighs sensors by their precision",
          "[weigh]") {
  // Forces exactly on the predicted mean pattern: every corrected reading is P, so P^ = P for any
  // covariance.
  Eigen::VectorXd mu(4), force(4);
  mu << 0.97, 1.04, 1.10, 0.93;
  const double P = 45e3;
  force = P * mu;
  Eigen::MatrixXd A(4, 4);
  A << 1, 0.3, 0.1, 0, 0.3, 2, 0.2, 0.1, 0.1, 0.2, 1.5, 0.4, 0, 0.1, 0.4, 1;
  const Eigen::MatrixXd C = 1e-3 * A * A.transpose();
  const auto c = weigh::combine_sensors(force, mu, C);
  CHECK(c.static_n == Approx(P).epsilon(1e-13));
  CHECK(c.weights.sum() == Approx(1.0).epsilon(1e-13));
  // Independent sensors, μ = 1: inverse-variance weights, variance 1 / Σ (1 / v_m).
  Eigen::VectorXd v(3), f(3);
  v << 1e-4, 4e-4, 2e-4;
  f << 41e3, 43e3, 42e3;
  const auto d = weigh::combine_sensors(f, Eigen::VectorXd::Ones(3), Eigen::MatrixXd(v.asDiagonal()));
  const Eigen::VectorXd w = v.cwiseInverse() / v.cwiseInverse().sum();
  CHECK(d.weights.isApprox(w, 1e-13));
  CHECK(d.static_n == Approx(w.dot(f)).epsilon(1e-13));
  CHECK(d.relative_variance == Approx(1.0 / v.cwiseInverse().sum()).epsilon(1e-13));
  // A covariance that is not positive definite is a numerical error, not a silent answer.
  CHECK_THROWS_AS(weigh::combine_sensors(f, Eigen::VectorXd::Ones(3), Eigen::MatrixXd::Zero(3, 3)), NumericalError);
}

TEST_CASE("the fixed point over the unknown sprung mass converges geometrically from the plain mean", "[weigh]") {
  // AS3, the roughest road: the predicted pattern depends most on the truck there. A light and a
  // heavy truck, so the start (the plain mean) is off the fixed point in both directions.
  const site::Site site(site::load_road("AS3"), site::SiteOptions{});
  const auto cloud = point_mass(fleet::FleetDistribution{}, 0.02);
  const auto log = simulate_forces(site, 6, 0.02, 31);
  weigh::WeighOptions options;
  for (std::size_t i = 0; i < log.records.size(); ++i) {
    weigh::FixedPointTrace trace;
    const auto w = weigh::estimate_static_weight(cloud, site, log.records[i], "test", options, &trace);
    const auto& e = trace.estimates_n;
    INFO("truck " << i << ": " << e.size() - 1 << " steps; plain mean " << e.front() << " N, fixed point " << e.back() << " N");
    REQUIRE(e.size() >= 2);
    CHECK(w.iterations == static_cast<int>(e.size()) - 1);
    CHECK(w.iterations <= 6);
    // A contraction: each step at most a fifth of the one before (while steps are above rounding).
    for (std::size_t k = 2; k < e.size(); ++k) {
      const double prev = std::abs(e[k - 1] - e[k - 2]), step = std::abs(e[k] - e[k - 1]);
      if (prev > 1e-9 * e.back()) CHECK(step <= 0.2 * prev);
    }
    // The last step is within the tolerance, and the first one really moved (the correction is
    // not a no-op on this road).
    CHECK(std::abs(e.back() - e[e.size() - 2]) <= options.relative_tolerance * e.back());
    CHECK(std::abs(e[1] - e[0]) > 1e-4 * e[0]);
    CHECK(w.static_kn == Approx(e.back() / 1e3).epsilon(1e-15));
  }
}

TEST_CASE("on simulated trucks the SSR-corrected estimate is unbiased and its 95 % intervals cover the truth", "[weigh]") {
  // 60 Table 1 trucks on AS3 with θ known. Relative errors e_i are independent across trucks, so
  // their mean is within 4 standard errors of 0 for an unbiased estimator. Coverage: with true
  // 95 % intervals the count inside is Binomial(60, 0.95), P(count < 53) = 1.0 %. And the
  // intervals are not too wide either: their mean half-width is 1.96 x the predicted sd, to be set
  // against 1.96 x the observed RMS error (known to about 9 % from 60 trucks): within [0.7, 1.4].
  const site::Site site(site::load_road("AS3"), site::SiteOptions{});
  const auto cloud = point_mass(fleet::FleetDistribution{}, 0.02);
  const int n = 60;
  const auto log = simulate_forces(site, n, 0.02, 77);
  const weigh::WeighOptions options;
  double sum = 0.0, sum_sq = 0.0, half_width = 0.0;
  int inside = 0;
  for (int i = 0; i < n; ++i) {
    const auto w = weigh::estimate_static_weight(cloud, site, log.records[static_cast<std::size_t>(i)], "test", options);
    const double truth_kn = log.static_n[static_cast<std::size_t>(i)] / 1e3;
    const double e = w.static_kn / truth_kn - 1.0;
    sum += e;
    sum_sq += e * e;
    half_width += 0.5 * (w.static_kn_q975 - w.static_kn_q025) / truth_kn;
    inside += (w.static_kn_q025 <= truth_kn && truth_kn <= w.static_kn_q975) ? 1 : 0;
  }
  const double mean = sum / n, rms = std::sqrt(sum_sq / n), sd = std::sqrt((sum_sq - n * mean * mean) / (n - 1));
  INFO("mean relative error " << mean << ", RMS " << rms << ", covered " << inside << " of " << n
                              << ", mean half-width " << half_width / n);
  CHECK(std::abs(mean) < 4.0 * sd / std::sqrt(n));
  CHECK(inside >= 53);
  CHECK(half_width / n / (1.96 * rms) > 0.7);
  CHECK(half_width / n / (1.96 * rms) < 1.4);
}

TEST_CASE("forces that imply no truck are a data error naming the record's line", "[weigh]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto cloud = point_mass(fleet::FleetDistribution{}, 0.02);
  records::ForceRecord r;
  r.truck_id = "tiny";
  r.speed_mps = 20.0;
  r.line = 7;
  r.force_n = Eigen::VectorXd::Constant(site.sensors(), 4000.0);  // 4 kN: less than the unsprung mass alone
  try {
    weigh::estimate_static_weight(cloud, site, r, "log.csv", weigh::WeighOptions{});
    FAIL("no error");
  } catch (const DataError& e) {
    CHECK(e.line() == 7);
    CHECK(e.field() == "force_1");
    CHECK(std::string(e.what()).find("log.csv:7") != std::string::npos);
  }
}
