// Batched random-walk Metropolis–Hastings on blocks of continuous coordinates, leaving π_φ
// invariant, with the proposal calibrated on the weighted particle cloud (particles'
// ArrayRandomWalk): N(0, (scale² / d) Σ̂) with Σ̂ the weighted covariance of the block and
// scale = 2.38 (Roberts, Gelman & Gilks 1997, optimal for Gaussian-like targets).
//
// One MH step proposes for ALL particles, asks the model for log γ and ℓ at all proposals in one
// call, then accepts or rejects per particle. A sweep is one step per block, then the model's
// custom moves. Sweeps repeat until every block's particles have moved far enough:
//
//   jump_b = Σ_i W_i ||x_i - x_i⁰||²_{Σ̂⁻¹} / (2 d_b) >= jump_target,
//
// where x⁰ is the block at the start of the moves. 2d is E||X - X'||²_{Σ⁻¹} for two independent
// draws from a distribution with covariance Σ, so jump_b → 1 for a perfectly mixed cloud; the
// default target 0.5 asks that particles have moved about one posterior sd per coordinate. The
// count is capped by max_steps (a poorly mixing block is reported through its acceptance rate
// and jump, not hidden). This is the idea of particles' AdaptiveMCMCSequence (stop when the
// mean squared jump stops growing), made scale free and with an absolute target.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "smc/parallel.hpp"
#include "smc/rng.hpp"
#include "smc/target.hpp"

namespace ssrfleet::smc {

struct MhOptions {
  double scale = 2.38;       // proposal sd multiplier of Σ̂^{1/2} / √d; > 0
  double jump_target = 0.5;  // in (0, 1]; see above
  int min_steps = 1;         // sweeps at least (>= 1)
  int max_steps = 20;        // sweeps at most (>= min_steps)
  // Between sweeps, each block's proposal is shrunk or widened by the share of particles that
  // accepted in the sweep just done (the tuning table of PyMC's Metropolis step), so a block
  // whose cloud is much wider than each particle's conditional (multimodal, or a latent tightly
  // tied to θ) still moves. The factor depends only on population averages of earlier sweeps,
  // so every sweep is a π_φ-invariant kernel and the result does not depend on thread count.
  bool adapt_scale = true;
  // Independence proposals (Chopin 2002's choice for IBIS): each sweep first proposes, for every
  // particle, a fresh draw from a multivariate t with `independence_df` degrees of freedom, centred
  // on the cloud's weighted mean with its weighted covariance times independence_inflation², and
  // accepts by the MH ratio with the proposal densities. Once the cloud is near its target (a
  // static-parameter posterior after a few records is close to Gaussian) most proposals are
  // accepted and each acceptance is an almost independent draw: the jump target is met in one or
  // two sweeps where a random walk in d dimensions needs ~3d. The random-walk step still runs in a
  // sweep whenever the last independence step accepted fewer than `independence_min_acceptance`.
  bool independence = false;
  double independence_df = 10.0;
  double independence_inflation = 1.2;
  double independence_min_acceptance = 0.3;
};

struct MhSummary {
  int sweeps = 0;
  std::vector<std::string> block_names;
  std::vector<double> acceptance;  // per block: mean acceptance rate over particles and sweeps
  std::vector<double> jump;        // per block: the final jump_b (see above)
  std::vector<double> scale_factor;  // per block: the adapted multiplier of the proposal at the end
  // Per block, with MhOptions::independence: the mean acceptance of the independence steps (-1
  // without them), and how many random-walk steps ran.
  std::vector<double> independence_acceptance;
  std::vector<int> random_walk_steps;
};

// The next proposal multiplier given the acceptance rate of the last sweep (PyMC's tune table).
double tuned_scale_factor(double factor, double acceptance);

// Σ̂ = Σ_i W_i (x_i - m)(x_i - m)ᵀ / Σ W, m = Σ W_i x_i / Σ W; X is d × P.
Eigen::MatrixXd weighted_covariance(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                    const Eigen::Ref<const Eigen::ArrayXd>& W);

// (scale² / d) Σ̂, with a relative 1e-10 ridge on the diagonal so a coordinate that has
// collapsed still gets a positive-definite proposal. NumericalError if the whole block has
// collapsed to one point (zero spread) or Σ̂ is not finite.
Eigen::MatrixXd proposal_covariance(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                    const Eigen::Ref<const Eigen::ArrayXd>& W, double scale);

// Runs the sweeps at temperature φ. log_base and loglik are the engine's cache of log γ and ℓ at
// the current states and are kept up to date. rngs: a node private to this call (the engine
// passes one keyed by stage and tempering step); sweep s, block b uses rngs.child(s, b).stream(i)
// for particle i. NumericalError names the particle, the block and the stage label if the
// model returns NaN.
MhSummary mh_moves(TemperedModel& model, double phi, const Eigen::Ref<const Eigen::ArrayXd>& W,
                   Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                   const RngFactory& rngs, const ParallelFor& parallel, const MhOptions& options,
                   std::string_view stage_label);

}  // namespace ssrfleet::smc
