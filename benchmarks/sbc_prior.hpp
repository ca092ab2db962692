// The prior of the simulation-based calibration (sbc_benchmark.cpp): the law θ is
// drawn from, and the prior the fit is given, so that the two are the same law.
//
// Why not the model's default priors (docs/model.md, fleet::PriorBounds{}): SBC needs the simulator and the
// model to share their support. The model's k ~ N(K, σ_k²) and k_t ~ N(K_t, σ_kt²) are untruncated,
// while a simulated truck is physical (fleet::draw_fleet truncates every stiffness to positive by
// rejection). Under the design box a draw such as σ_kt = 2e6 beside K_t = 5e5 makes a third of
// the tyres negative in the model and none in the simulator, so the ranks would measure that
// mismatch, not the sampler. Here every σ is at most a quarter of the smallest mean it can meet:
//   σ_k  <= 85e3  <= 350e3 / 4.1,   σ_kt <= 350e3 = 1.4e6 / 4,
// so P(k < 0) <= Φ(−4.1) = 1.9e-5 and P(k_t < 0) <= Φ(−4) = 3.2e-5 per truck at the worst corner
// of the box: at most 2.6e-3 per 50-truck replication that a truck's stiffness would differ
// between the two, and much less averaged over the box. The lateral position is truncated to the
// road in both (fleet_model.hpp, draw_fleet), so Z and σ_z may push trucks to an edge.
//
// The box is centred near the paper's Table 1 fleet (K 500e3 ± 50e3, K_t 1.95e6 ± 195e3, Z 1.5 ±
// 0.5, σ_IF 0.02) and wide enough to be a real test: K ± 30 %, K_t from −28 % to +28 %, each fleet
// sd over a factor 3-4.4 (from well below what 50 trucks resolve to above Table 1's), Z over a
// metre, σ_IF over a factor 4. Masses and speeds, which the WIM system measures and the model takes
// as known, keep Table 1's laws.
#pragma once

#include <cstdint>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "smc/rng.hpp"

namespace ssrfleet::bench {

inline fleet::PriorBounds sbc_prior() {
  fleet::PriorBounds p;
  //      K       sigma_k  Kt      sigma_kt  Z    sigma_z  sigma_IF
  p.lo = {350e3, 20e3, 1.40e6, 80e3, 1.0, 0.25, 0.010};
  p.hi = {650e3, 85e3, 2.50e6, 350e3, 2.0, 0.75, 0.040};
  return p;
}

// The worst-corner probability that a truck's k or k_t is negative, Φ(−lo(mean) / hi(sd)), for
// the report and for a check that the box keeps it negligible.
inline double worst_negative_stiffness_probability(const fleet::PriorBounds& p) {
  return fleet::normal_cdf(-p.lo[fleet::kK] / p.hi[fleet::kSigmaK]) +
         fleet::normal_cdf(-p.lo[fleet::kKt] / p.hi[fleet::kSigmaKt]);
}

// θ uniform on the box, each coordinate one uniform from `rng` in fleet_model.hpp order.
inline fleet::HyperVector draw_from_box(const fleet::PriorBounds& p, smc::Rng& rng) {
  fleet::HyperVector theta{};
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto J = static_cast<std::size_t>(j);
    theta[J] = p.lo[J] + (p.hi[J] - p.lo[J]) * smc::uniform01(rng);
  }
  return theta;
}

// The fleet whose hyperparameters are θ (σ_IF is the simulator's noise, not part of the fleet);
// sprung mass and speed as Table 1 (FleetDistribution defaults).
inline fleet::FleetDistribution fleet_of(const fleet::HyperVector& theta) {
  fleet::FleetDistribution d;
  d.stiffness_npm = {theta[fleet::kK], theta[fleet::kSigmaK]};
  d.tyre_stiffness_npm = {theta[fleet::kKt], theta[fleet::kSigmaKt]};
  d.lateral_m = {theta[fleet::kZ], theta[fleet::kSigmaZ]};
  return d;
}

// One SBC replication's data: the fleet and the noise from `data_seed` (the simulator keeps the
// two streams independent), θ's σ_IF as the noise.
inline fleet::SimulatedLog simulate_sbc_log(const site::Site& site, const fleet::HyperVector& theta, int trucks,
                                            std::uint64_t data_seed) {
  const std::vector<records::Truck> drawn =
      fleet::draw_fleet(fleet_of(theta), trucks, site.lateral_min_m(), site.lateral_max_m(), data_seed);
  return fleet::simulate_log(site, drawn, theta[fleet::kSigmaIf], data_seed);
}

}  // namespace ssrfleet::bench
