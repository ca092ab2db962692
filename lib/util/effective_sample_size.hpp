// Effective sample size of Markov chains by Geyer's initial monotone sequence estimator
// (Geyer 1992, "Practical Markov chain Monte Carlo", Statistical Science 7(4), §3.3), in the
// multi-chain form of Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021), "Rank-normalization,
// folding, and localization: an improved R-hat for assessing convergence of MCMC", Bayesian
// Analysis 16(2), which is what Stan and ArviZ report.
//
// M chains of N draws, chain m with mean θ̄_m, autocovariances γ_m(t) (divisor N, the biased
// estimator Geyer uses) and variance s_m² = γ_m(0) N/(N-1):
//
//   W = mean_m s_m²,  var⁺ = (N-1)/N W + var_m(θ̄_m)   (var_m with divisor M-1; 0 when M = 1)
//   ρ(t) = 1 - (W - mean_m γ_m(t)) / var⁺  for t > 0,  ρ(0) = 1
//
// so that between-chain differences lower every ρ(t) and with it the ESS. The pairs
// P_k = ρ(2k) + ρ(2k+1) are positive, decreasing and convex for a reversible chain: the sum runs
// over the initial positive pairs (stopping at lag N-4 at the latest), each clipped to its
// predecessor, and the even term ρ(2K) of the first pair not summed is added when it is positive
// or that pair's sum is not negative, which lowers the variance for antithetic chains:
//
//   τ = -1 + 2 Σ_{k<K} P_k + ρ(2K),   ESS = M N / τ,   τ >= 1 / log10(M N),
//
// the floor on τ capping the ESS at M N log10(M N), since antithetic chains can otherwise report
// absurd values. One chain (M = 1) gives ρ(t) = γ(t)/γ(0): Geyer's estimator with those two additions.
//
// The autocovariances come from one FFT of the zero-padded chain, so the cost is O(N log N) a chain.
#pragma once

#include <Eigen/Core>

namespace ssrfleet {

// Autocovariances gamma(0..max_lag) of the chain (divisor n), through unsupported/Eigen/FFT.
Eigen::VectorXd autocovariance(const Eigen::Ref<const Eigen::VectorXd>& chain, Eigen::Index max_lag);

// ESS of the draws, one column a chain (all of one length). NaN for chains shorter than 4 draws,
// a non-finite draw, or draws all equal (no information about the spread, and NaN compares false
// against any threshold).
double multi_chain_effective_sample_size(const Eigen::Ref<const Eigen::MatrixXd>& chains);

// ESS of one chain: the above with one column.
double chain_effective_sample_size(const Eigen::Ref<const Eigen::VectorXd>& chain);

}  // namespace ssrfleet
