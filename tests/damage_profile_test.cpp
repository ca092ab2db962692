// The damage along the road against known answers: a deterministic IF pattern
// gives the closed form, a fleet without spread gives the single vehicle's value, and normally
// distributed forces give Eisenmann's road stress factor E[IF^4] = 1 + 6 DLC² + 3 DLC⁴.
#include <cmath>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <catch2/catch.hpp>

#include "damage/damage_profile.hpp"
#include "model/fleet_model.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "vehicle/quarter_car.hpp"

using namespace ssrfleet;

namespace {
double esal(double wheel_load_n) { return std::pow(2.0 * wheel_load_n / 80e3, 4); }
}  // namespace

TEST_CASE("a deterministic IF pattern gives the closed form of every column", "[damage]") {
  // Two θ draws of two trucks at three positions. Position 0: every truck at IF c (no spread);
  // position 1: the trucks of draw r at 1 - d_r and 1 + d_r (a two-point fleet); position 2: static.
  const std::vector<double> positions = {10.0, 20.0, 30.0};
  const double c = 1.05, d0 = 0.1, d1 = 0.2, load = 45e3;
  Eigen::ArrayXXd wheel_if(3, 4);
  wheel_if << c, c, c, c,  //
      1 - d0, 1 + d0, 1 - d1, 1 + d1,  //
      1, 1, 1, 1;
  const Eigen::ArrayXd loads = Eigen::ArrayXd::Constant(4, load);
  damage::DamageOptions options;
  options.extra_powers = {2.0};
  const auto p = damage::summarise_damage(positions, wheel_if, loads, 2, 2, options);

  REQUIRE(p.powers.size() == 3);
  CHECK(p.powers[0].power == 1.0);
  CHECK(p.powers[1].power == 4.0);
  CHECK(p.powers[2].power == 2.0);
  // Position 0: a_n = c^n exactly, no spread over θ, DLC 0, a hot spot (c^4 = 1.2155 > 1.1).
  for (const auto& a : p.powers) {
    CHECK(a.mean[0] == Approx(std::pow(c, a.power)).epsilon(1e-14));
    CHECK(a.q025[0] == Approx(std::pow(c, a.power)).epsilon(1e-14));
    CHECK(a.q975[0] == Approx(std::pow(c, a.power)).epsilon(1e-14));
  }
  CHECK(p.dlc[0] == Approx(0.0).margin(1e-12));
  CHECK(p.hot_spot[0]);
  // Position 1: a1 = 1, a2 = 1 + d², a4 = 1 + 6 d² + d⁴ per draw, DLC = d (plug-in sd); the
  // limits are the type-7 quantiles of the two draws' values.
  const auto a4 = [](double d) { return 1 + 6 * d * d + std::pow(d, 4); };
  CHECK(p.powers[0].mean[1] == Approx(1.0).epsilon(1e-14));
  CHECK(p.powers[2].mean[1] == Approx(1 + (d0 * d0 + d1 * d1) / 2).epsilon(1e-14));
  CHECK(p.powers[1].mean[1] == Approx((a4(d0) + a4(d1)) / 2).epsilon(1e-14));
  CHECK(p.powers[1].q025[1] == Approx(a4(d0) + 0.025 * (a4(d1) - a4(d0))).epsilon(1e-14));
  CHECK(p.powers[1].q975[1] == Approx(a4(d0) + 0.975 * (a4(d1) - a4(d0))).epsilon(1e-14));
  CHECK(p.dlc[1] == Approx((d0 + d1) / 2).epsilon(1e-12));
  // Hot spot from the 95th percentile of a4 over θ: a4(d0) = 1.0601, a4(d1) = 1.2416, so the
  // 95th percentile, 1.2325, exceeds 1.1 although a4(d0) alone does not.
  CHECK(p.hot_spot[1]);
  // Position 2: static, nothing amplified, no hot spot.
  CHECK(p.powers[1].mean[2] == Approx(1.0).epsilon(1e-14));
  CHECK_FALSE(p.hot_spot[2]);
  // ESAL: (2 P / 80 kN)^4 per truck, a million trucks; the static one is the same trucks standing.
  CHECK(p.static_esal_per_million == Approx(1e6 * esal(load)).epsilon(1e-12));
  CHECK(p.esal_per_million[0] == Approx(1e6 * esal(c * load)).epsilon(1e-12));
  CHECK(p.esal_per_million[1] == Approx(1e6 * esal(load) * (a4(d0) + a4(d1)) / 2).epsilon(1e-12));
  CHECK(p.lift_off_passes == 0);

  // A threshold above the 95th percentile turns the hot spots off.
  options.hot_spot_threshold = 1.3;
  const auto high = damage::summarise_damage(positions, wheel_if, loads, 2, 2, options);
  CHECK_FALSE(high.hot_spot[0]);
  CHECK_FALSE(high.hot_spot[1]);
}

TEST_CASE("a wheel in the air loads the pavement with nothing, and is counted", "[damage]") {
  Eigen::ArrayXXd wheel_if(1, 4);
  wheel_if << -0.2, 1.0, 1.0, 1.0;
  const auto p = damage::summarise_damage({5.0}, wheel_if, Eigen::ArrayXd::Constant(4, 40e3), 2, 2, damage::DamageOptions{});
  CHECK(p.lift_off_passes == 1);
  CHECK(p.powers[1].mean[0] == Approx((0.0 + 1.0 + 2.0) / 4).epsilon(1e-14));  // draws: (0+1)/2 and 1
}

TEST_CASE("normally distributed forces give Eisenmann's road stress factor 1 + 6 DLC^2 + 3 DLC^4", "[damage]") {
  // IF = 1 + s Z, Z ~ N(0, 1), in R θ draws of T trucks (all draws alike). a4 is then the mean of
  // N = R T independent values IF^4, so its Monte Carlo sd is sqrt(Var(IF^4) / N), with the
  // normal moments E[IF^4] = 1 + 6 s² + 3 s⁴ and
  // E[IF^8] = Σ_k C(8, 2k) s^(2k) (2k - 1)!! = 1 + 28 s² + 210 s⁴ + 420 s⁶ + 105 s⁸.
  // At s = 0.3 and N = 400,000: sd 0.0028, so four sd (0.011) is well inside the 3 s⁴ = 0.024 a
  // formula without the kurtosis term would miss by. IF < 0 (Z < -3.3, 4e-4 of the trucks)
  // counts as 0; its share of E[IF^4] is below 1e-8.
  const int R = 200, T = 2000;
  const double s = 0.3;
  boost::random::mt19937_64 engine(20240518);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  Eigen::ArrayXXd wheel_if(1, R * T);
  for (Eigen::Index b = 0; b < wheel_if.cols(); ++b) wheel_if(0, b) = 1.0 + s * normal(engine);
  const double load = 50e3;
  const auto p = damage::summarise_damage({50.0}, wheel_if, Eigen::ArrayXd::Constant(R * T, load), R, T,
                                          damage::DamageOptions{});

  const double s2 = s * s, s4 = s2 * s2;
  const double e4 = 1 + 6 * s2 + 3 * s4, e8 = 1 + 28 * s2 + 210 * s4 + 420 * s4 * s2 + 105 * s4 * s4;
  const double mc_sd = std::sqrt((e8 - e4 * e4) / (static_cast<double>(R) * T));
  INFO("a4 " << p.powers[1].mean[0] << ", Eisenmann " << e4 << ", Monte Carlo sd " << mc_sd);
  CHECK(std::abs(p.powers[1].mean[0] - e4) < 4 * mc_sd);
  // The DLC is the mean over draws of the plug-in sd: bias about -3 s / (4 T) = -1.1e-4 (inside
  // the s / T allowed), sd s / sqrt(2 T R) over the R draws.
  CHECK(std::abs(p.dlc[0] - s) < 4 * s / std::sqrt(2.0 * T * R) + s / T);
  // Eisenmann in the reported quantities themselves: a4 against the DLC the same run reports (the
  // DLC's error enters through the slope 12 s + 12 s³ of the factor).
  const double d2 = p.dlc[0] * p.dlc[0];
  const double dlc_error = 4 * s / std::sqrt(2.0 * T * R) + s / T;
  CHECK(std::abs(p.powers[1].mean[0] - (1 + 6 * d2 + 3 * d2 * d2)) < 4 * mc_sd + (12 * s + 12 * s * s2) * dlc_error);
  // With one static load for all, the dynamic damage is the static damage times a4, exactly.
  CHECK(p.esal_per_million[0] == Approx(p.static_esal_per_million * p.powers[1].mean[0]).epsilon(1e-12));
}

TEST_CASE("a fleet with no spread gives the single vehicle's value at every position", "[damage]") {
  // The posterior is a point mass at θ whose spreads are a millionth of the means (σ_z 1 µm) and
  // the traffic is one observed truck, so every simulated truck is that truck: a_n must be its own
  // IF^n, the DLC zero, the limits equal. The residual spread moves the IF by ~1e-6 at most.
  const site::Site site(site::load_road("AS3"), site::SiteOptions{});
  const double K = 480e3, Kt = 2.0e6, Z = 1.7, v = 22.0, m2 = 4300.0;
  fleet::PosteriorCloud cloud;
  cloud.method = "smc";
  Eigen::VectorXd th(fleet::kHyperCount);
  th << K, K * 1e-6, Kt, Kt * 1e-6, Z, 1e-6, 0.02;
  cloud.theta = th.replicate(1, 3);
  cloud.weights = Eigen::ArrayXd::Constant(3, 1.0 / 3);
  cloud.speed_mps = {v};
  cloud.sprung_mass_kg = {m2};
  damage::DamageOptions options;
  options.theta_draws = 4;
  options.trucks_per_draw = 5;
  options.extra_powers = {2.5};
  const auto p = damage::predict_damage(cloud, site, {}, options);

  site::TruckBatch one;
  one.resize(1);
  one.speed_mps[0] = v;
  one.sprung_mass_kg[0] = m2;
  one.stiffness_npm[0] = K;
  one.tyre_stiffness_npm[0] = Kt;
  one.lateral_m[0] = Z;
  Eigen::ArrayXXd single(site.sensors(), 1);
  site.impact_factors(one, single);
  const double static_n = (m2 + site.options().unsprung_mass_kg) * vehicle::gravity_mps2;

  REQUIRE(p.position_m.size() == static_cast<std::size_t>(site.sensors()));
  int hot = 0;
  for (int m = 0; m < site.sensors(); ++m) {
    const auto i = static_cast<std::size_t>(m);
    const double x = single(m, 0);
    INFO("sensor " << m + 1 << ": single-vehicle IF " << x);
    for (const auto& a : p.powers) {
      CHECK(a.mean[i] == Approx(std::pow(x, a.power)).epsilon(1e-5));
      CHECK(a.q975[i] - a.q025[i] < 1e-5);
    }
    CHECK(p.dlc[i] < 1e-5);
    CHECK(p.hot_spot[i] == (std::pow(x, 4) > 1.1));
    CHECK(p.esal_per_million[i] == Approx(1e6 * esal(x * static_n)).epsilon(1e-5));
    hot += p.hot_spot[i] ? 1 : 0;
  }
  CHECK(p.static_esal_per_million == Approx(1e6 * esal(static_n)).epsilon(1e-12));
  INFO("hot spots: " << hot);
  CHECK(hot > 0);  // AS3 is rough enough for this truck to have some: the flag is exercised both ways
  CHECK(hot < site.sensors());
}
