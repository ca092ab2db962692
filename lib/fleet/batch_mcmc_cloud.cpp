#include "fleet/batch_mcmc_cloud.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "util/effective_sample_size.hpp"

namespace ssrfleet::fleet {

PosteriorCloud to_posterior_cloud(const BatchMcmcResult& result, const site::Site& site,
                                  const std::vector<records::WimRecord>& records, const ModelExtension* extension) {
  PosteriorCloud c;
  c.method = "mcmc";
  c.theta = result.theta_draws.transpose();
  const Eigen::Index draws = result.theta_draws.rows();
  c.weights = Eigen::ArrayXd::Constant(draws, draws > 0 ? 1.0 / static_cast<double>(draws) : 0.0);
  for (const auto& r : records) {
    c.speed_mps.push_back(r.speed_mps);
    c.sprung_mass_kg.push_back(r.sprung_mass_kg);
  }
  c.site_fingerprint = site.fingerprint();
  c.road_name = site.surface().name;
  c.sensors = site.sensors();
  c.lateral_min_m = site.lateral_min_m();
  c.lateral_max_m = site.lateral_max_m();
  c.trucks_seen = static_cast<long>(records.size());
  double ess = std::numeric_limits<double>::infinity();
  for (int j = 0; j < kHyperCount; ++j) {
    const double e = chain_effective_sample_size(result.theta_draws.col(j));
    ess = std::isnan(e) ? ess : std::min(ess, e);  // a constant column (a pinned box edge) says nothing
  }
  c.weight_ess = static_cast<double>(draws);
  c.min_ess = std::isfinite(ess) ? ess : static_cast<double>(draws);
  c.log_evidence = std::numeric_limits<double>::quiet_NaN();
  if (extension != nullptr) {
    c.model = extension->name();
    for (const auto& p : extension->parameters()) c.psi_names.push_back(p.name);
    c.psi = result.psi_draws.transpose();
  }
  return c;
}

}  // namespace ssrfleet::fleet
