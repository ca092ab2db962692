// Several independent chains of the batch MCMC (batch_mcmc.hpp) and the diagnostics that compare
// them: rank-normalised split-R̂, bulk- and tail-ESS and the Monte Carlo standard errors of the
// mean and of the 5 % and 95 % quantiles, per hyperparameter and per ψ (util/convergence.hpp;
// Vehtari, Gelman, Simpson, Carpenter & Bürkner 2021). One chain cannot show that it has not
// converged; chains from over-dispersed starts that disagree can.
//
// Chain c runs the options given with seed chain_seed(seed, c) (chain 0: the seed itself, so one
// chain is the single-chain run bit for bit) and, for c ≥ 1, θ's start over-dispersed
// (BatchMcmcOptions::start_dispersion). `iterations`, `burn_in` and `thin` count per chain. The
// chains run side by side, as many at once as there are threads, each on its share of them; a
// chain's draws do not depend on its thread count, so neither do the results.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_cloud.hpp"
#include "fleet/posterior_cloud.hpp"
#include "util/convergence.hpp"

namespace ssrfleet::fleet {

struct BatchMcmcChainsOptions {
  BatchMcmcOptions chain;      // every chain's options (seed: chain 0's; threads: all the chains')
  int chains = 4;
  double start_dispersion = 1.0;  // for chains 1, 2, ...
  bool IsValid(std::string* error) const;
};

std::uint64_t chain_seed(std::uint64_t seed, int chain);

// UsageError on invalid options; the batch MCMC's errors otherwise. The chains in order.
std::vector<BatchMcmcResult> run_batch_mcmc_chains(const site::Site& site, const std::vector<records::WimRecord>& records,
                                                   const BatchMcmcChainsOptions& options);

// The convergence of each hyperparameter, then each ψ, over the chains' kept draws (their names:
// kHyperNames, then the extension's parameters).
std::vector<ParameterConvergence> chain_convergence(const std::vector<BatchMcmcResult>& chains,
                                                    const ModelExtension* extension);

// The posterior of the pooled chains (every kept draw, equal weights), with `chains` and
// `convergence` filled; min_ess is the smallest bulk-ESS over the hyperparameters.
PosteriorCloud to_posterior_cloud(const std::vector<BatchMcmcResult>& chains, const site::Site& site,
                                  const std::vector<records::WimRecord>& records, const ModelExtension* extension);

}  // namespace ssrfleet::fleet
