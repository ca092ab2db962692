// Ancillary (non-centred) hyperparameter updates for the batch MCMC (batch_mcmc.hpp): the
// "interweaving" of Yu & Meng (2011, "To centre or not to centre: that is not the question",
// JCGS 20(3)), ASIS.
//
// The centred steps of the batch MCMC draw (K, sigma_k) given the latents k_1..N. When the data
// pin each k_n only loosely (per-truck posterior sd ≈ 0.44 population sd for k, 0.63 for kt, from
// the Fisher information of 16 impact factors: Table 1 fleet, a 35e-6 road, σ_IF = 0.02), k_1..N
// and (K, sigma_k) are strongly dependent a posteriori and that step moves little. The ancillary
// step holds the standardised values eps_n = (k_n - K) / sigma_k fixed instead and moves
// (K, sigma_k) given eps and the data: every k_n = K + sigma_k eps_n moves with them, so every
// truck is re-simulated (one batched integrator call of N passes per proposal).
//
// Target of one ancillary step, for the block (mean M, scale S) of latent coordinate x:
// the joint density of (theta, x_1..N) is p(theta) prod_n f(x_n | M, S) L_n(x_n) with
// f the normal density (truncated to the road [lo, hi] for z). Changing variables
// x_n = M + S eps_n (dx_n = S deps_n) the 1/S of each f cancels the Jacobian S, so
//
//   p(theta | eps, y) ∝ p(theta) prod_n phi(eps_n) / P_n(M, S) * 1[x_n in support] * L_n(M + S eps_n)
//
// where P(M, S) = P(lo <= x <= hi) under N(M, S^2) for z (1 for k, kt), phi(eps_n) is constant
// here, and the support is x > 0 for k, kt (the integrator has no meaning there: the chain gives
// it likelihood 0, as the centred latent step does) and [lo, hi] for z. For z this keeps the
// standardised value rather than the truncated-normal CDF value u_n: eps is then only nearly
// ancillary (exactly so when the truncation does not bind), which costs nothing in validity,
// only, in principle, some efficiency; proposals putting any z_n off the road are rejected.
//
// The proposal is a random walk in (M, log S): (M', log S') = (M, log S) + step * N(0, I), with a
// Jacobian S'/S in the acceptance ratio (a symmetric walk in log S is not symmetric in S), and
// (M', S') outside the prior box rejected. The walk's per-coordinate step is
// exp(log_scale) * base_sd; during burn-in base_sd follows the chain's sd of (M, log S) and
// log_scale a Robbins-Monro recursion towards the target acceptance; both are frozen after burn-in,
// so the kept chain is time-homogeneous.
#pragma once

#include <functional>

#include <Eigen/Core>
#include <boost/random/mersenne_twister.hpp>

#include "model/fleet_model.hpp"

namespace ssrfleet::fleet {

// Per-truck sums of squared residuals of candidate values of one latent coordinate (the other two
// held at their current values): fills ssr_out (size of values) and may return +inf for a truck.
using AncillarySsrFunction = std::function<void(const Eigen::ArrayXd& values, Eigen::ArrayXd& ssr_out)>;

class AncillaryUpdater {
 public:
  // mean_index/sd_index: kK/kSigmaK, kKt/kSigmaKt or kZ/kSigmaZ; latent: the matching Latent.
  // truncated: the latent is truncated to range (z). trucks: N (>= 1).
  AncillaryUpdater(Hyper mean_index, Hyper sd_index, bool truncated, int trucks);

  // One MH step on (theta[mean], theta[sd]) with eps = (latent - mean) / sd held fixed.
  // latent and ssr (the per-truck SSR of the current state, size N) are updated on acceptance.
  // inv2var_if = 1 / (2 sigma_IF^2). Draws two normals and, if the proposal is inside the prior
  // box and the support (and so was simulated), one uniform, all from engine, in that order.
  // adapt: burn-in (the step size adapts); collect: burn-in past its transient (the chain's
  // moments feed base_sd). Returns true on acceptance.
  bool step(boost::random::mt19937_64& engine, HyperVector& theta, Eigen::Ref<Eigen::ArrayXd> latent,
            Eigen::Ref<Eigen::ArrayXd> ssr, double inv2var_if, const AncillarySsrFunction& ssr_of,
            const PriorBounds& prior, const LateralRange& range, double target_acceptance, bool adapt,
            bool collect);

  long long tried() const { return tried_; }
  long long accepted() const { return accepted_; }
  // Resets the counts (the caller does so at the end of burn-in, so they cover kept sweeps only).
  void reset_counts() { tried_ = accepted_ = 0; }
  double log_scale() const { return log_scale_; }

 private:
  Hyper mean_index_, sd_index_;
  bool truncated_;
  int trucks_;
  double log_scale_ = 0.0;
  Eigen::Vector2d base_sd_;  // in (mean, log sd) units; zero until the first step sets it
  bool base_set_ = false;
  // Welford moments of (mean, log sd) over burn-in steps, for base_sd_.
  long long moment_count_ = 0;
  Eigen::Vector2d moment_mean_ = Eigen::Vector2d::Zero(), moment_m2_ = Eigen::Vector2d::Zero();
  long long adapt_steps_ = 0;
  long long tried_ = 0, accepted_ = 0;
  Eigen::ArrayXd eps_, proposal_, ssr_proposal_;
};

}  // namespace ssrfleet::fleet
