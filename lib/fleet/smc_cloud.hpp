// The posterior cloud of an SMC core, whichever core: its particles' θ and weights, the sampler's
// ESS and evidence, and the site it was fitted on (posterior_cloud.hpp). Both cores hand out their
// posterior through this one function, so the file a prediction reads cannot differ by core.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"
#include "site/site.hpp"
#include "smc/engine.hpp"

namespace ssrfleet::fleet {

inline PosteriorCloud smc_cloud(const site::Site& site, const smc::TemperedSampler& sampler, const Eigen::MatrixXd& theta,
                                std::vector<double> speed_mps, std::vector<double> sprung_mass_kg, long trucks_seen) {
  PosteriorCloud c;
  c.method = "smc";
  c.theta = theta;
  c.weights = sampler.weights();
  c.speed_mps = std::move(speed_mps);
  c.sprung_mass_kg = std::move(sprung_mass_kg);
  c.site_fingerprint = site.fingerprint();
  c.road_name = site.surface().name;
  c.sensors = site.sensors();
  c.lateral_min_m = site.lateral_min_m();
  c.lateral_max_m = site.lateral_max_m();
  c.trucks_seen = trucks_seen;
  c.weight_ess = sampler.ess();
  c.log_evidence = sampler.log_evidence();
  return c;
}

}  // namespace ssrfleet::fleet
