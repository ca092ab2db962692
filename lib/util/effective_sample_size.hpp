// Effective sample size of one scalar Markov chain by Geyer's initial monotone sequence estimator
// (Geyer 1992, "Practical Markov chain Monte Carlo", Statistical Science 7(4), §3.3):
//
//   Gamma_m = gamma(2m) + gamma(2m+1) is positive, decreasing and convex for a reversible chain;
//   sum the empirical Gamma_m while they stay positive, each clipped to its predecessor, then
//   tau = -1 + 2 sum_m Gamma_m / gamma(0),  ESS = n / tau.
//
// The autocovariances gamma(t) (divisor n, the biased estimator Geyer uses) come from one FFT
// of the zero-padded chain, so the cost is O(n log n).
#pragma once

#include <Eigen/Core>

namespace ssrfleet {

// Autocovariances gamma(0..max_lag) of the chain (divisor n), through unsupported/Eigen/FFT.
Eigen::VectorXd autocovariance(const Eigen::Ref<const Eigen::VectorXd>& chain, Eigen::Index max_lag);

// ESS of the chain. NaN for a chain shorter than 4 draws or a constant chain (no information
// about the spread, and NaN compares false against any threshold). The estimate is capped at
// n log10(n) (as Stan does), since antithetic chains can otherwise report absurd values.
double chain_effective_sample_size(const Eigen::Ref<const Eigen::VectorXd>& chain);

}  // namespace ssrfleet
