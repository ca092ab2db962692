// The batch MCMC's output in the shape every consumer of a fit reads (posterior_cloud.hpp): the
// kept theta draws as an equally weighted cloud, so the posterior JSON and the SSR prediction do
// not care which sampler produced them.
#pragma once

#include <vector>

#include "fleet/batch_mcmc.hpp"
#include "fleet/posterior_cloud.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

// method "mcmc"; theta kHyperCount x kept draws; equal weights; min_ess = the smallest Geyer chain ESS
// over the seven hyperparameters (the figure that limits every summary); log_evidence NaN (the
// batch sampler does not estimate it). With the extension the chain fitted: its name as the model
// and its ψ draws.
PosteriorCloud to_posterior_cloud(const BatchMcmcResult& result, const site::Site& site,
                                  const std::vector<records::WimRecord>& records,
                                  const ModelExtension* extension = nullptr);

}  // namespace ssrfleet::fleet
