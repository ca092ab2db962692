// What a fit leaves behind for prediction: weighted draws of the hyperparameters θ, the observed
// trucks' speeds and sprung masses (the predictive draws v and m2 from them, docs/model.md), and
// enough about the site to refuse a prediction that mixes up sites.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ssrfleet::fleet {

// One site of a fit over several sites (docs/sites.md): what the cloud's top-level site
// fields hold for a fit of one site, and where its trucks sit in the cloud's speed and mass pool.
struct CloudSite {
  std::string name;               // the manifest's name for it
  std::string fingerprint;        // site::Site::fingerprint()
  std::string road_name;
  int sensors = 0;
  double lateral_min_m = 0.0, lateral_max_m = 0.0;
  long trucks_seen = 0;
  std::size_t pool_begin = 0, pool_count = 0;  // speed_mps[pool_begin, pool_begin + pool_count)
};

// The sensor calibration one site's records were corrected with before the fit (docs/sites.md):
// sensor j read gain[j] x the true impact factor. `se` holds the gains' standard errors when the
// fit estimated them (fit --calibrate); empty for a known calibration (a manifest's).
struct SiteCalibration {
  std::string site;  // the manifest's name for it
  std::vector<double> gain;
  std::vector<double> se;
};

// How well one parameter's draws are converged, from several independent runs (Vehtari et al.
// 2021). MCMC chains (fleet/batch_mcmc_chains.hpp): R̂ (rank-normalised split, the larger of bulk
// and tail), bulk- and tail-ESS, and the Monte Carlo standard errors of the mean and of the 5 % and
// 95 % quantiles from the chains' autocorrelation; ess_equivalent NaN. SMC runs
// (fleet/smc_runs.hpp): R̂ of the runs' equal-weight draws, not split (a run's draws have no
// order); the MCSEs from the spread of the runs' means and quantiles; the equivalent ESS, the
// number of independent draws whose mean would have the pooled mean's Monte Carlo error; bulk- and
// tail-ESS NaN (they measure a chain's autocorrelation, which a run does not have).
struct ParameterConvergence {
  std::string name;
  double rhat = 0.0, ess_bulk = 0.0, ess_tail = 0.0;
  double mcse_mean = 0.0, mcse_q05 = 0.0, mcse_q95 = 0.0;
  double ess_equivalent = std::numeric_limits<double>::quiet_NaN();
};

struct PosteriorCloud {
  std::string method;             // "smc" or "mcmc"
  Eigen::MatrixXd theta;          // kHyperCount x draws (fleet_model.hpp order)
  Eigen::ArrayXd weights;         // normalised, one per draw (equal for MCMC)
  std::vector<double> speed_mps;  // observed trucks
  std::vector<double> sprung_mass_kg;
  std::string site_fingerprint;   // site::Site::fingerprint() of the fitted site
  std::string road_name;
  int sensors = 0;
  double lateral_min_m = 0.0, lateral_max_m = 0.0;
  long trucks_seen = 0;
  // SMC: the weights' ESS of one sweep's cloud (of the P particles; of R independent runs pooled,
  // R² / Σ_r 1/ESS_r, the ESS of their particles each weighted 1/R). MCMC: the kept draws' count.
  double weight_ess = 0.0;
  // MCMC: the smallest ESS over the hyperparameters (several chains: bulk-ESS; one chain: Geyer's
  // ESS of the chain); NaN for SMC, whose Monte Carlo error "convergence" gives with several runs.
  double min_ess = std::numeric_limits<double>::quiet_NaN();
  // The independent runs pooled in theta, their draws one after the other in equal counts: MCMC
  // chains, or SMC runs (fit --runs, each run's weights scaled to sum to 1/chains); and each
  // parameter's convergence over them (empty for one run).
  int chains = 1;
  std::vector<ParameterConvergence> convergence;
  // SMC: the number of final sweeps whose clouds are pooled in theta (each particle's weight shared
  // over its copies); 0: theta is the particles as they stand (an online stream, or no final sweeps).
  int pooled_sweeps = 0;
  double log_evidence = 0.0;      // log p(y_1:n), SMC only (NaN for MCMC)
  // The model fitted (model/model_spec.hpp): "base", or a spec such as
  // "tyre_damping+sensor_gain:sensor=11", and the draws of its free parameters ψ, one row per
  // parameter (psi_names, the extension's parameter names), one column per draw (0 rows for base).
  std::string model = "base";
  std::vector<std::string> psi_names;
  Eigen::MatrixXd psi;
  // A fit over several sites: one entry per site, in the fit's order (empty for a fit of one site).
  // The top-level site fields then describe the whole: the joint fingerprint (fleet/joint_sites.hpp),
  // the roads joined by '+', the first site's sensors and lateral range; the pool holds every site's
  // trucks, site by site.
  std::vector<CloudSite> sites;
  // Per site, in the fit's order, when any site's records were corrected (empty otherwise). Predict
  // does not use it: a gain is the instrument's, not the force the road feels.
  std::vector<SiteCalibration> calibration;
};

}  // namespace ssrfleet::fleet
