// Several independent SMC runs on one log (fit --runs R), pooled into one posterior, and what
// their agreement says about its Monte Carlo error. One SMC run's weighted cloud cannot show its
// own error: its weights' ESS counts particles, not independent draws of the posterior, and the
// MCMC moves leave the particles correlated. R runs from independent seeds can: the scatter of
// their estimates is the error itself (the "equivalent ESS" of the benchmarks, now per fit).
//
// Run r's seed is run_seed(seed, r): run 0 is the seed itself, so one run is the plain fit bit for
// bit, and the others are independent streams below it. A run is a whole fit, its checkpoints
// keyed by its own seed and spread over MPI ranks as any fit is; the runs go one after the other.
//
// Per parameter x (each hyperparameter, then each ψ), from runs r = 1..R with normalised weights
// w_r over their particles (the same count P in every run):
//   the run's mean m_r = Σ w x and its weighted 5 % and 95 % quantiles (posterior_summary.hpp);
//   R̂ = util::rhat_unsplit of the runs' equal-weight draws (systematic, offset 1/2:
//       equal_weight_draws.hpp), P per run, rank-normalised and not split: a run's draws have no
//       order, so halves of a run are not two chains (util/convergence.hpp);
//   MCSE of the pooled mean = sd_r(m_r) / √R (divisor R - 1), and of the pooled 5 % and 95 %
//       quantiles the same of the runs' quantiles (the pooled quantile is close to their mean);
//   equivalent ESS = (pooled posterior sd / MCSE of the mean)²: how many independent draws would
//       estimate the mean as well as the R runs together do.
// The scatter of R runs is known to a χ²(R - 1)/(R - 1) factor in its square: with 90 %
// probability the MCSE estimated is 0.34 to 1.6 times the true one for R = 4, 0.56 to 1.4 for R = 8
// and 0.73 to 1.26 for R = 20. Bulk- and tail-ESS are left NaN: they measure a chain's
// autocorrelation, which a run's draws do not have.
#pragma once

#include <cstdint>
#include <vector>

#include "fleet/posterior_cloud.hpp"

namespace ssrfleet::fleet {

std::uint64_t run_seed(std::uint64_t seed, int run);

// The diagnostics above, one entry per hyperparameter then per ψ (names: kHyperNames, then
// cloud.psi_names). std::invalid_argument for fewer than 2 runs or runs of different shapes.
std::vector<ParameterConvergence> run_convergence(const std::vector<PosteriorCloud>& runs);

// The runs as one posterior: theta and psi run after run, each run's weights scaled to sum to 1/R;
// chains = R and convergence = run_convergence(runs); weight_ess = R² / Σ_r 1/ESS_r (the ESS of
// all the particles so weighted); log_evidence the log of the mean of the runs' evidence (each
// run's estimate of p(y) is unbiased, so their mean is too). The rest is run 0's: every run must be
// of the same site, log, model and shape (std::invalid_argument naming what differs). One run is
// returned as it is.
PosteriorCloud pool_runs(const std::vector<PosteriorCloud>& runs);

}  // namespace ssrfleet::fleet
