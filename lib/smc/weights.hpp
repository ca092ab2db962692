// Importance weights in log space. Notation: logw unnormalised log weights, W normalised weights
// (sum 1), ℓ the log-likelihood increment being tempered in, δ the temperature step, so the
// incremental weight of particle i is w_i = exp(δ ℓ_i).
//
// ℓ_i = -inf is allowed (the particle has zero likelihood; its weight becomes 0 for any δ > 0);
// NaN is not (the callers check for it and name the particle, see tempering.hpp).
#pragma once

#include <Eigen/Core>

namespace ssrfleet::smc {

// log Σ exp(a_i), stable (max shifted out). -inf when a is empty or all -inf.
double log_sum_exp(const Eigen::Ref<const Eigen::ArrayXd>& a);

// W_i = exp(logw_i - log_sum_exp(logw)). NumericalError if every weight is zero (all -inf).
Eigen::ArrayXd normalised_weights(const Eigen::Ref<const Eigen::ArrayXd>& logw);

// Kish's effective sample size 1 / Σ W_i², in [1, P] for normalised W.
double effective_sample_size(const Eigen::Ref<const Eigen::ArrayXd>& W);

// The δ ℓ_i of one step, with 0 · (-inf) read as 0 (a step of zero changes nothing).
Eigen::ArrayXd log_increment(const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta);

// Conditional ESS of Zhou, Johansen & Aston (2016, eq. 3.16) for the step δ:
//   CESS = P (Σ W_i w_i)² / Σ W_i w_i²,  w_i = exp(δ ℓ_i),
// in [1, P]; equal to the ESS after the step when the weights before it were equal. It measures
// how well the current weighted cloud represents the next target, not the degeneracy of the
// cumulative weights, which is why tempering steps are chosen with it (ESS would stop moving
// once weights are unequal).
double conditional_ess(const Eigen::Ref<const Eigen::ArrayXd>& W,
                       const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta);

// CESS / P, in [1/P, 1] (particles' ESSrmin convention: a fraction of the particle count).
double relative_conditional_ess(const Eigen::Ref<const Eigen::ArrayXd>& W,
                                const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta);

// log Σ W_i exp(δ ℓ_i): the step's log normalising-constant ratio estimate log(Z_φ' / Z_φ).
// Summed over steps (whether or not the cloud was resampled in between), it gives log Z.
double log_mean_weight_increment(const Eigen::Ref<const Eigen::ArrayXd>& W,
                                 const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta);

}  // namespace ssrfleet::smc
