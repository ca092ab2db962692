// Where the batch MCMC's chain starts (batch_mcmc.hpp, "Initialisation"): every truck's latents
// (given, each truck's best fit, or a grid search over z), their residuals, and θ from them.
// Internal to the sampler (namespace detail); no random number is drawn here.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_residuals.hpp"
#include "model/fleet_model.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet::detail {

struct ChainStart {
  Eigen::MatrixXd latents;  // trucks x 3 (k, k_t, z), the records' order
  Eigen::ArrayXd ssr;       // each truck's sum of squared residuals at its latents (and ψ)
  HyperVector theta{};
  long long fit_passes = 0;  // integrator passes of the best-fit searches (outside the evaluator)
};

// UsageError if options.initial_latents has the wrong number of rows or an unphysical row.
// psi: the extension's parameters the residuals are computed at (null without an extension).
ChainStart start_chain(const site::Site& site, const std::vector<records::WimRecord>& records,
                       const BatchMcmcOptions& options, const Observations& obs, ResidualEvaluator& evaluator,
                       const double* psi);

}  // namespace ssrfleet::fleet::detail
