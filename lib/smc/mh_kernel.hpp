// The MCMC sweeps of a TemperedSampler, leaving π_φ invariant, with proposals calibrated on the
// weighted particle cloud. Two block moves (on the model's blocks of continuous coordinates):
//   random walk   N(0, (scale² / d) Σ̂), Σ̂ the block's weighted covariance, scale = 2.38
//                 (Roberts, Gelman & Gilks 1997; particles' ArrayRandomWalk);
//   independence  a multivariate t fitted to the cloud (MhOptions).
// and the model's own moves (TemperedModel::model_moves). Which run, in what order and when is the
// MoveSchedule (move_schedule.hpp); this file runs it.
//
// One MH step proposes for ALL particles, asks the model for log γ and ℓ at all proposals in one
// call, then accepts or rejects per particle. A sweep is the schedule's moves in order. Sweeps
// repeat until every block's particles have moved far enough:
//
//   jump_b = Σ_i W_i ||x_i - x_i⁰||²_{Σ̂⁻¹} / (2 d_b) >= jump_target,
//
// where x⁰ is the block at the start of the moves. 2d is E||X - X'||²_{Σ⁻¹} for two independent
// draws from a distribution with covariance Σ, so jump_b → 1 for a perfectly mixed cloud; the
// default target 0.5 asks that particles have moved about one posterior sd per coordinate. The
// count is capped by max_sweeps (a poorly mixing block is reported through its acceptance rate
// and jump, not hidden). This is the idea of particles' AdaptiveMCMCSequence (stop when the
// mean squared jump stops growing), made scale free and with an absolute target.
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "smc/move_schedule.hpp"
#include "smc/parallel.hpp"
#include "smc/rng.hpp"
#include "smc/target.hpp"

namespace ssrfleet::smc {

// How the block moves propose (which moves run, and how often, is the MoveSchedule's).
struct MhOptions {
  double scale = 2.38;  // random-walk proposal sd multiplier of Σ̂^{1/2} / √d; > 0
  // Between sweeps, each block's random-walk proposal is shrunk or widened by the share of
  // particles that accepted in the sweep just done (the tuning table of PyMC's Metropolis step), so
  // a block whose cloud is much wider than each particle's conditional (multimodal, or a latent
  // tightly tied to θ) still moves. The factor depends only on population averages of earlier
  // sweeps, so every sweep is a π_φ-invariant kernel and the result does not depend on thread count.
  bool adapt_scale = true;
  // The independence proposal (Chopin 2002's choice for IBIS): for every particle a fresh draw from
  // a multivariate t with `independence_df` degrees of freedom, centred on the cloud's weighted mean
  // with its weighted covariance times independence_inflation², accepted by the MH ratio with the
  // proposal densities. Once the cloud is near its target (a static-parameter posterior after a few
  // records is close to Gaussian) most proposals are accepted and each acceptance is an almost
  // independent draw: the jump target is met in one or two sweeps where a random walk in d
  // dimensions needs ~3d.
  double independence_df = 10.0;
  double independence_inflation = 1.2;
};

// What one scheduled move did over the sweeps of one call: one record per schedule entry and
// block (model moves have no block).
struct MoveRecord {
  std::string move;   // "independence", "random walk" or the model move's name
  std::string block;  // the block's name; "" for a model move
  int runs = 0;       // times it ran
  int skipped = 0;    // times its condition (φ, per-stage limit, previous acceptance) held it back
  // Mean share of particles that accepted over its runs; NaN for a move that reports none (Gibbs).
  double acceptance = std::numeric_limits<double>::quiet_NaN();
};

struct MhSummary {
  int sweeps = 0;
  std::vector<std::string> block_names;
  // Per block: the mean acceptance of its random-walk runs (of its independence runs if the random
  // walk never ran), the final jump_b (see above) and the adapted random-walk multiplier.
  std::vector<double> acceptance;
  std::vector<double> jump;
  std::vector<double> scale_factor;
  std::vector<MoveRecord> moves;  // every schedule entry (x block), in schedule order

  // The record of `move` on `block` ("" for a model move); nullptr if the schedule has none.
  const MoveRecord* find(std::string_view move, std::string_view block = "") const;
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

// Runs the schedule's sweep at temperature φ, between `min_sweeps` and `max_sweeps` times (the
// jump target decides in between). log_base and loglik are the engine's cache of log γ and ℓ at
// the current states and are kept up to date. rngs: a node private to this call (the engine
// passes one keyed by stage and tempering step); sweep s, block b uses rngs.child(s, b).stream(i)
// for particle i. runs_in_stage: per schedule entry, its runs earlier in this stage (updated; for
// max_runs_per_stage). NumericalError names the particle, the block and the stage label if the
// model returns NaN; UsageError if the schedule names a model move the model does not have.
// after_sweep, if set, is called after each sweep with its 0-based index, the model holding the
// states that sweep left (a caller that pools every sweep's cloud reads them there).
using SweepObserver = std::function<void(int sweep)>;
MhSummary run_sweeps(TemperedModel& model, double phi, const Eigen::Ref<const Eigen::ArrayXd>& W,
                     Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik, const RngFactory& rngs,
                     const ParallelFor& parallel, const MhOptions& proposal, const MoveSchedule& schedule,
                     int min_sweeps, int max_sweeps, std::vector<int>& runs_in_stage, std::string_view stage_label,
                     const SweepObserver& after_sweep = {});

}  // namespace ssrfleet::smc
