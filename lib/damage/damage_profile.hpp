// The damage a fleet does along the road: from the posterior predictive trucks
// (fleet/predictive_trucks.hpp, the same draws as the SSR prediction) simulated through the site,
// the damage amplification a_n = E[IF^n] for n = 1, 4 and any further n, the dynamic load
// coefficient, hot spots and the expected damage in equivalent standard axles
// (records/damage_profile.hpp has the definitions).
//
// The expectations over the fleet are per θ draw, over its T simulated trucks; the reported value
// is their mean over the R θ draws and the limits their 2.5 / 97.5 % quantiles. P is the model's
// tyre force: no measurement noise (σ_IF describes the sensors, not the pavement's load).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"
#include "fleet/vehicle_classes.hpp"
#include "records/damage_profile.hpp"
#include "site/site.hpp"

namespace ssrfleet::damage {

// The standard axle of the fourth-power law (AASHO road test; Cebon, Handbook of vehicle-road
// interaction): 80 kN, and an axle carries twice the quarter car's wheel load.
inline constexpr double kStandardAxleN = 80e3;
inline constexpr double kWheelsPerAxle = 2.0;

struct DamageOptions {
  std::vector<double> extra_powers;  // further n beyond 1 and 4 (each > 0, none repeated)
  double hot_spot_threshold = 1.1;   // on a_4, as a multiple of the static value (> 0)
  int theta_draws = 200;             // θ draws (limits over the posterior)
  int trucks_per_draw = 100;         // simulated trucks per θ draw (a Latin hypercube)
  bool traffic_bootstrap = true;     // weigh the observed (v, m2) by a Bayesian bootstrap per θ draw
  std::uint64_t seed = 1;

  void validate() const;  // UsageError naming the option
  std::vector<double> powers() const;  // 1, 4, then extra_powers
};

// The pure summary, from simulated tyre forces: wheel_if is positions x (R * T) impact factors,
// θ-draw-major (column r * T + t), static_load_n the static wheel load of each column. Needs
// R >= 2 and T >= 1. A negative IF (lift-off) loads the pavement with nothing: it counts as 0.
// truck_weight (empty = equal): T weights >= 0 summing to 1, truck t of every θ draw weighing
// truck_weight[t] in that draw's expectations (a mixture of classes: a class's trucks weigh its
// share over T); trucks of weight 0 count in no pass total.
records::DamageProfile summarise_damage(const std::vector<double>& position_m, const Eigen::ArrayXXd& wheel_if,
                                        const Eigen::ArrayXd& static_load_n, int theta_draws, int trucks_per_draw,
                                        const DamageOptions& options, const Eigen::ArrayXd& truck_weight = {});

// The whole computation: predictive trucks from the posterior, simulated at positions_m (strictly
// increasing, on the road; empty = the site's sensors), summarised.
records::DamageProfile predict_damage(const fleet::PosteriorCloud& posterior, const site::Site& site,
                                      std::vector<double> positions_m, const DamageOptions& options);

// A mixture of vehicle classes (fleet/vehicle_classes.hpp), class c weighing shares[c]: each
// class's predictive trucks drawn with the seed fleet::class_seed(options.seed, label) and
// simulated; θ draw r of the mixture is draw r of every class (their posteriors are independent),
// and every expectation over the fleet (a_n, DLC, ESAL, static ESAL) is over the mixture, each
// class's trucks weighing its share. One class of share > 0 is exactly that class's predict_damage.
records::DamageProfile predict_damage_mixture(const fleet::ClassPosteriors& classes, const std::vector<double>& shares,
                                              const site::Site& site, std::vector<double> positions_m,
                                              const DamageOptions& options);

}  // namespace ssrfleet::damage
