// Latents drawn from a marginal-core fit (discrepancy/marginal_draws.hpp): the table's proposal
// corrected by Metropolis-Hastings with the integrator must give draws from the exact conditional
// p(k, k_t, z | y, θ), whose moments brute-force integration computes independently.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "discrepancy/marginal_draws.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/truck_table.hpp"
#include "site/road_source.hpp"

using namespace ssrfleet;

namespace {

struct Moments {
  double mean_k = 0.0, sd_k = 0.0, mean_kt = 0.0, sd_kt = 0.0, mean_z = 0.0, sd_z = 0.0;
};

// E and sd of k, k_t and z under p(k, k_t, z | y, θ), with p(k, k_t | y, θ) ∝ N(k | K, σ_k²)
// N(k_t | K_t, σ_kt²) ∫ p(y | k, k_t, z) N(z | Z, σ_z²) dz by a 41 x 41 rectangle rule over ±8 sd of
// the fit's likelihood combined with the fleet (error far below the Monte Carlo tolerance), and the
// z-integral and z's moments at each node by the brute-force reference.
Moments exact_moments(const site::Site& site, const records::WimRecord& r, const fleet::HyperVector& th) {
  model::TruckTableOptions o;
  o.sigma_ref = th[fleet::kSigmaIf];
  const model::TruckFit f = model::fit_truck(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, o);
  const double lk = f.stiffness_sd_per_sigma * th[fleet::kSigmaIf], lkt = f.tyre_stiffness_sd_per_sigma * th[fleet::kSigmaIf];
  const double sk = th[fleet::kSigmaK], skt = th[fleet::kSigmaKt];
  const double wk = 1 / std::sqrt(1 / (sk * sk) + 1 / (lk * lk)), wkt = 1 / std::sqrt(1 / (skt * skt) + 1 / (lkt * lkt));
  const double ck = (f.stiffness_npm / (lk * lk) + th[fleet::kK] / (sk * sk)) * wk * wk;
  const double ckt = (f.tyre_stiffness_npm / (lkt * lkt) + th[fleet::kKt] / (skt * skt)) * wkt * wkt;
  constexpr int G = 41;
  constexpr double R = 8.0;
  std::vector<double> k, kt, logw, z1, z2;
  for (int a = 0; a < G; ++a) {
    for (int b = 0; b < G; ++b) {
      const double x = ck - R * wk + 2 * R * wk * a / (G - 1), y = ckt - R * wkt + 2 * R * wkt * b / (G - 1);
      if (x <= 0.0 || y <= 0.0) continue;
      k.push_back(x);
      kt.push_back(y);
      model::ZMoments zm;
      logw.push_back(model::reference_log_z_integral(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, x, y,
                                                     th[fleet::kSigmaIf], th[fleet::kZ], th[fleet::kSigmaZ], &zm) +
                     fleet::log_normal_density(x, th[fleet::kK], sk) + fleet::log_normal_density(y, th[fleet::kKt], skt));
      z1.push_back(zm.mean);
      z2.push_back(zm.second);
    }
  }
  const double top = *std::max_element(logw.begin(), logw.end());
  double w0 = 0, k1 = 0, k2 = 0, t1 = 0, t2 = 0, s1 = 0, s2 = 0;
  for (std::size_t g = 0; g < k.size(); ++g) {
    const double w = std::exp(logw[g] - top);
    w0 += w;
    k1 += w * k[g];
    k2 += w * k[g] * k[g];
    t1 += w * kt[g];
    t2 += w * kt[g] * kt[g];
    s1 += w * z1[g];
    s2 += w * z2[g];
  }
  Moments m;
  m.mean_k = k1 / w0;
  m.sd_k = std::sqrt(k2 / w0 - m.mean_k * m.mean_k);
  m.mean_kt = t1 / w0;
  m.sd_kt = std::sqrt(t2 / w0 - m.mean_kt * m.mean_kt);
  m.mean_z = s1 / w0;
  m.sd_z = std::sqrt(s2 / w0 - m.mean_z * m.mean_z);
  return m;
}

}  // namespace

TEST_CASE("latents drawn from a marginal-core fit follow the exact conditional of k, k_t and z", "[discrepancy][model][heavy]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 30, site.lateral_min_m(), site.lateral_max_m(), 5);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 5);
  fleet::MarginalSmc::Options o;
  o.sampler.particles = 256;
  o.sampler.threads = 2;
  fleet::MarginalSmc smc(site, o);
  for (const auto& r : log.records) smc.absorb(r);
  // θ at the truth: the tables' lattice and nodes were chosen around the posterior, which holds it.
  const fleet::HyperVector theta{500e3, 50e3, 1950e3, 195e3, 1.5, 0.5, 0.02};
  constexpr int kDraws = 1500;
  std::vector<std::vector<double>> k(3), kt(3), z(3);
  discrepancy::MarginalDrawStats stats;
  const smc::RngFactory root(2024);
  for (int d = 0; d < kDraws; ++d) {
    const auto drawn = discrepancy::draw_truck_latents(site, smc.target(), theta, root.child(static_cast<std::uint64_t>(d)),
                                                       8, &stats);
    REQUIRE(drawn.latents.size() == log.records.size());
    for (int i = 0; i < 3; ++i) {
      k[static_cast<std::size_t>(i)].push_back(drawn.latents[static_cast<std::size_t>(i)].stiffness_npm);
      kt[static_cast<std::size_t>(i)].push_back(drawn.latents[static_cast<std::size_t>(i)].tyre_stiffness_npm);
      z[static_cast<std::size_t>(i)].push_back(drawn.latents[static_cast<std::size_t>(i)].lateral_m);
    }
  }
  // The independence sampler starts from the table's mixture, which is close to the target.
  INFO("MH acceptance " << stats.acceptance());
  CHECK(stats.acceptance() > 0.4);
  for (int i = 0; i < 3; ++i) {
    const Moments exact = exact_moments(site, log.records[static_cast<std::size_t>(i)], theta);
    auto mean_sd = [](const std::vector<double>& v) {
      double m = 0, s = 0;
      for (double x : v) m += x;
      m /= static_cast<double>(v.size());
      for (double x : v) s += (x - m) * (x - m);
      return std::pair{m, std::sqrt(s / static_cast<double>(v.size() - 1))};
    };
    const auto [mk, sdk] = mean_sd(k[static_cast<std::size_t>(i)]);
    const auto [mkt, sdkt] = mean_sd(kt[static_cast<std::size_t>(i)]);
    const auto [mz, sdz] = mean_sd(z[static_cast<std::size_t>(i)]);
    INFO("truck " << i << ": k " << mk << " +- " << sdk << " (exact " << exact.mean_k << " +- " << exact.sd_k << "), k_t "
                  << mkt << " +- " << sdkt << " (exact " << exact.mean_kt << " +- " << exact.sd_kt << "), z " << mz
                  << " +- " << sdz << " (exact " << exact.mean_z << " +- " << exact.sd_z << ")");
    // Independent chains, one draw each: the mean's Monte Carlo sd is sd / sqrt(draws), the sd's
    // about sd / sqrt(2 draws); 4 of them each.
    const double n = kDraws;
    CHECK(std::abs(mk - exact.mean_k) < 4.0 * exact.sd_k / std::sqrt(n));
    CHECK(std::abs(mkt - exact.mean_kt) < 4.0 * exact.sd_kt / std::sqrt(n));
    CHECK(std::abs(sdk / exact.sd_k - 1.0) < 4.0 / std::sqrt(2.0 * n));
    CHECK(std::abs(sdkt / exact.sd_kt - 1.0) < 4.0 / std::sqrt(2.0 * n));
    CHECK(std::abs(mz - exact.mean_z) < 4.0 * exact.sd_z / std::sqrt(n));
    CHECK(std::abs(sdz / exact.sd_z - 1.0) < 4.0 / std::sqrt(2.0 * n));
  }
}

TEST_CASE("posterior draws from a marginal-core fit do not depend on the thread count", "[discrepancy]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 12, site.lateral_min_m(), site.lateral_max_m(), 3);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 3);
  fleet::MarginalSmc::Options o;
  o.sampler.particles = 128;
  fleet::MarginalSmc smc(site, o);
  for (const auto& r : log.records) smc.absorb(r);
  discrepancy::MarginalDrawOptions d;
  d.draws = 20;
  d.threads = 1;
  const auto one = discrepancy::posterior_draws(site, smc, d);
  d.threads = 2;
  const auto two = discrepancy::posterior_draws(site, smc, d);
  REQUIRE(one.model_if.size() == 20);
  for (std::size_t i = 0; i < one.model_if.size(); ++i) {
    CHECK(one.model_if[i] == two.model_if[i]);
    CHECK(one.lateral_m[i] == two.lateral_m[i]);
    CHECK(one.stiffness_pit[i] == two.stiffness_pit[i]);
  }
  d.mh_steps = -1;
  CHECK_THROWS_WITH(discrepancy::posterior_draws(site, smc, d), Catch::Contains("mh_steps"));
}
