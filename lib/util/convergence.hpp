// Convergence diagnostics of MCMC draws as Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021),
// "Rank-normalization, folding, and localization: an improved R-hat for assessing convergence of
// MCMC", Bayesian Analysis 16(2), define them, and as Stan (stansummary) and ArviZ (az.summary)
// report them: one scalar quantity, draws × chains, chains >= 1 of equal length.
//
// Split chains. Each chain of N draws is cut into its first and second halves of ⌊N/2⌋ draws (the
// middle draw of an odd N is left out), so a trend within one chain shows as a difference between
// chains: M chains become 2M.
//
// Rank normalisation. Every draw of the split chains gets its rank r among all S of them (ties
// their average rank) and is replaced by z = Φ⁻¹((r - 3/8) / (S + 1/4)) (Blom's scores). R̂ and
// ESS of z are those of a normal quantity with the same dependence, defined whatever the tails
// of the draws (no mean or variance is needed) and unchanged by any increasing transformation.
//
// R̂ of split chains y (M' chains of N' draws, chain means ȳ_m and variances s_m², divisor N'-1):
//   W = mean_m s_m²,  B/N' = var_m(ȳ_m) (divisor M'-1),  R̂ = √(((N'-1)/N' W + B/N') / W).
// Bulk R̂ is R̂ of the rank-normalised split chains; tail R̂ that of the folded draws
// |θ - median(θ)| (median over all draws), rank-normalised and split, which sees chains that agree
// in location but not in scale. R̂ = max(bulk R̂, tail R̂); the paper asks for R̂ < 1.01.
// Unsplit R̂ is the same max of bulk and tail R̂ of the chains as they are, not split: for
// independent runs whose draws have no order within a run (an SMC run's equal-weight draws), where
// halves of a run are not two chains. For runs of N independent draws each, R̂² ≈ 1 + B/W - 1/N, B
// the variance of the runs' means and W the within-run variance: runs whose means scatter by a tenth
// of a posterior sd give R̂ ≈ 1.005.
//
// ESS (util/effective_sample_size.hpp: Geyer's initial monotone sequence on the multi-chain
// autocorrelation):
//   bulk-ESS  ESS of the rank-normalised split chains: the efficiency in the bulk;
//   ESS of a quantile q_p  ESS of the split indicator chains I(θ <= q̂_p), q̂_p the type-7 sample
//             quantile of all draws (util/quantile.hpp);
//   tail-ESS  min(ESS of q_0.05, ESS of q_0.95): the efficiency of the 90 % interval's ends;
//   ESS of the mean  ESS of the split chains themselves (meaningful for finite variance only).
//
// MCSE. Of the mean: sd(θ) / √(ESS of the mean), sd over all draws (divisor S-1). Of a quantile
// q_p (the paper's method; mcse_quantile of the R package posterior): with E = ESS of q_p, the
// Beta(E p + 1, E (1-p) + 1) distribution of the probability below q̂_p has its Φ(-1) and Φ(1)
// quantiles a₋ and a₊; the sorted draws θ_(1) <= … <= θ_(S) give the interval
// [θ_(max(⌊a₋ S⌋, 1)), θ_(min(⌈a₊ S⌉, S))], about one Monte Carlo sd of q̂_p on each side, and
// the MCSE is its half width.
//
// Undefined values are NaN, not errors: any non-finite draw, draws all equal, or chains shorter
// than the estimators need (R̂: 2 draws a split chain; ESS: 4). Only malformed arguments throw.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "util/parallel_range.hpp"

namespace ssrfleet::util {

// One quantity's diagnostics, with the summaries a reader compares them to.
struct ConvergenceSummary {
  Eigen::Index chains = 0;                 // M, before splitting
  Eigen::Index draws_per_chain = 0;        // N
  double mean = 0.0;                       // over all draws
  double sd = 0.0;                         // over all draws, divisor S - 1
  double q05 = 0.0, q50 = 0.0, q95 = 0.0;  // type-7 sample quantiles of all draws
  double rhat = 0.0;                       // max(rhat_bulk, rhat_tail)
  double rhat_bulk = 0.0;                  // rank-normalised split R̂
  double rhat_tail = 0.0;                  // rank-normalised split R̂ of the folded draws
  double rhat_unsplit = 0.0;               // max of bulk and tail R̂ of the chains not split
  double ess_bulk = 0.0;
  double ess_tail = 0.0;  // min(ess_q05, ess_q95)
  double ess_q05 = 0.0, ess_q95 = 0.0;
  double ess_mean = 0.0;
  double mcse_mean = 0.0;
  double mcse_q05 = 0.0, mcse_q95 = 0.0;
};

// The split chains: columns 2c and 2c+1 are the first and second halves of chain c (⌊N/2⌋ draws
// each). Chains of one draw are returned as they are.
Eigen::MatrixXd split_chains(const Eigen::Ref<const Eigen::MatrixXd>& draws);

// Blom's normal scores of the ranks of all entries together (ties: average rank), in place of each.
Eigen::MatrixXd rank_normalise(const Eigen::Ref<const Eigen::MatrixXd>& draws);

// R̂ of the chains as given (no splitting, no ranks): the classic potential scale reduction.
double basic_rhat(const Eigen::Ref<const Eigen::MatrixXd>& chains);

double rhat_bulk(const Eigen::Ref<const Eigen::MatrixXd>& draws);
double rhat_tail(const Eigen::Ref<const Eigen::MatrixXd>& draws);
// max(rhat_bulk, rhat_tail): NaN when either is.
double rhat(const Eigen::Ref<const Eigen::MatrixXd>& draws);
// The same of the chains not split (independent runs' unordered draws): NaN when either is.
double rhat_unsplit(const Eigen::Ref<const Eigen::MatrixXd>& draws);

double ess_bulk(const Eigen::Ref<const Eigen::MatrixXd>& draws);
// ESS of the p-quantile's indicator, p in (0, 1).
double ess_quantile(const Eigen::Ref<const Eigen::MatrixXd>& draws, double p);
double ess_tail(const Eigen::Ref<const Eigen::MatrixXd>& draws);
double ess_mean(const Eigen::Ref<const Eigen::MatrixXd>& draws);

double mcse_mean(const Eigen::Ref<const Eigen::MatrixXd>& draws);
double mcse_quantile(const Eigen::Ref<const Eigen::MatrixXd>& draws, double p);

// Everything above for one quantity, draws × chains. Throws std::invalid_argument for no draws or
// no chains.
ConvergenceSummary summarise_convergence(const Eigen::Ref<const Eigen::MatrixXd>& draws);

// A set of parameters: chains[c] is chain c, draws × parameters, every chain of one shape (as a
// sampler records them); the result has one summary per parameter, in column order. Throws
// std::invalid_argument for no chains or chains of different shapes. The parameters may be
// summarised in parallel (each on its own: the same bits for any chunking).
std::vector<ConvergenceSummary> summarise_parameters(const std::vector<Eigen::MatrixXd>& chains,
                                                     const ParallelRange& parallel = serial_range);

}  // namespace ssrfleet::util
