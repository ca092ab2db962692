// The posterior predictive of the fitted log, draw by draw, for the draws file's
// posterior_predictive group (io/draws_netcdf.hpp): for a capped subset of the equal-weight draws
// (fleet/equal_weight_draws.hpp) and of the observed trucks, each truck's impact factors at the
// sensors as a new truck of the same speed and sprung mass would give them under that draw:
//   k ~ N(K, sigma_k^2) on k > 0 (or the model's own stiffness distribution), k_t ~ N(K_t, sigma_kt^2)
//   on k_t > 0, z ~ N(Z, sigma_z^2) on the road's width, simulated through the site (with the draw's
//   psi when the model has effects), plus N(0, sigma_IF^2) noise on every sensor.
// The subset keeps `draws` draws of each chain evenly spread over it (draw floor((i + 1/2) D / n)),
// so a pooled SMC cloud's sweeps all take part, and the first `trucks` trucks of the log.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "fleet/equal_weight_draws.hpp"
#include "fleet/posterior_cloud.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

// The cap: 100 draws of each chain x 1,000 trucks, about 10^5 passes (seconds on one core).
inline constexpr Eigen::Index kPredictiveDrawsCap = 100;
inline constexpr Eigen::Index kPredictiveTrucksCap = 1000;

struct PosteriorPredictiveDraws {
  std::vector<Eigen::Index> draw_index;  // the draws of each chain used, as numbered in the posterior
  Eigen::Index trucks = 0;
  // Row (c * draw_index.size() + i) * trucks + t: chain c's draw draw_index[i], truck t; one column
  // per sensor.
  Eigen::MatrixXd impact_factor;
};

// max_draws, max_trucks: the cap (each at least 1; fewer when the draws or the log hold fewer).
// One random stream from `seed`, consumed in a fixed order: the same seed gives the same bits.
// UsageError when the posterior's model cannot be rebuilt on `site` or a draw's lateral
// distribution misses the road.
PosteriorPredictiveDraws posterior_predictive_draws(const site::Site& site, const PosteriorCloud& cloud,
                                                    const EqualWeightDraws& draws,
                                                    const std::vector<records::WimRecord>& observed,
                                                    Eigen::Index max_draws, Eigen::Index max_trucks,
                                                    std::uint64_t seed);

}  // namespace ssrfleet::fleet
