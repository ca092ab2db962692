// One particle of the latent core (fleet/fleet_target.hpp) in the batch MCMC's layout, so tests can
// hand it to fleet::log_posterior_unnormalised and compare the two samplers' densities.
#pragma once

#include <Eigen/Core>

#include "fleet/fleet_target.hpp"
#include "model/fleet_model.hpp"

namespace ssrfleet::test {

inline fleet::HyperVector particle_theta(const fleet::FleetTarget& target, Eigen::Index particle) {
  fleet::HyperVector theta;
  for (int h = 0; h < fleet::kHyperCount; ++h) theta[static_cast<std::size_t>(h)] = target.theta()(h, particle);
  return theta;
}

// trucks x 3: (k, k_t, z) of every kept truck of the particle.
inline Eigen::MatrixXd particle_latents(const fleet::FleetTarget& target, Eigen::Index trucks, Eigen::Index particle) {
  Eigen::MatrixXd latents(trucks, 3);
  for (Eigen::Index j = 0; j < trucks; ++j) latents.row(j) = target.truck_latents(j).col(particle).transpose();
  return latents;
}

}  // namespace ssrfleet::test
