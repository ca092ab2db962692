// What fleet_target.cpp and fleet_target_moves.cpp share: the latent core's one normal draw.
#pragma once

#include <cmath>

#include "smc/rng.hpp"

namespace ssrfleet::fleet::detail {

// Standard normal by Box-Muller on the counter-based stream (fixed forever, like uniform01: the
// latent core's checkpoints and seeds depend on it).
inline double standard_normal(smc::Rng& rng) {
  double u1 = smc::uniform01(rng);
  while (u1 <= 0.0) u1 = smc::uniform01(rng);
  const double u2 = smc::uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace ssrfleet::fleet::detail
