// What a model supplies to the tempered SMC engine. The engine owns the weights, the ancestors,
// the temperature φ and the random streams; the model owns the particle states.
//
// A *stage* tempers one log-likelihood increment ℓ into the current target:
//   π_φ(x) ∝ γ(x) · exp(φ ℓ(x)),  φ: 0 → 1,
// where γ is the stage's base density: the prior (static tempering, ℓ = the full log-likelihood)
// or, in a data-tempered (IBIS-like) stage, the previous posterior times the prior of the latent
// variables the model has just added for the new record (ℓ = that record's log-likelihood).
//
// The model returns log γ and ℓ *separately*, never log π_φ itself. The engine then caches both
// per particle and gets log π_φ = log γ + φ ℓ at any φ for free: each MCMC proposal is evaluated
// exactly once, the current states are never re-evaluated, and the ℓ of the next tempering step
// is already known after the moves. log γ may drop a constant, but the same one for every
// particle and every call within a stage (in practice: return the full log density, including
// the terms of blocks not being moved, or the cache goes stale between blocks).
#pragma once

#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "smc/parallel.hpp"
#include "smc/rng.hpp"

namespace ssrfleet::smc {

// A block of continuous coordinates moved together by random-walk Metropolis–Hastings.
struct BlockSpec {
  std::string name;  // for summaries and error messages
  Eigen::Index dim = 0;
};

class TemperedModel {
 public:
  virtual ~TemperedModel() = default;

  // P, the number of particles; fixed for the engine's lifetime.
  virtual Eigen::Index particles() const = 0;

  // log γ(x_i) and ℓ(x_i) at every particle's current state (called once at the start of each
  // stage, after the model has extended its particles for the new record). ℓ may be -inf.
  virtual void log_density(Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                           const ParallelFor& parallel) = 0;

  // The MH blocks of the current stage (may change between stages, e.g. the newest record's
  // latents). May be empty if the model only has custom moves.
  virtual std::vector<BlockSpec> blocks() const = 0;

  // Current values of one block: values is dim × P, column i = particle i.
  virtual void get_block(int block, Eigen::Ref<Eigen::MatrixXd> values) const = 0;

  // log γ and ℓ at the proposals, ALL particles in one call (so a batched simulator can run them
  // in lock-step): column i of `proposed` replaces block `block` of particle i, everything else
  // as now. Return -inf outside the support; NaN is an error.
  virtual void log_density_at(int block, const Eigen::Ref<const Eigen::MatrixXd>& proposed,
                              Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                              const ParallelFor& parallel) = 0;

  // Particles with accepted[i] != 0 take column i of `proposed` (the matrix last passed to
  // log_density_at for this block, so a model may keep what it computed there).
  virtual void accept(int block, const std::vector<char>& accepted,
                      const Eigen::Ref<const Eigen::MatrixXd>& proposed) = 0;

  // New particle i becomes a copy of old particle ancestors[i].
  virtual void resample(const std::vector<Eigen::Index>& ancestors) = 0;

  // Under MoveSchedule::Trigger::kAfterResampling, whether this stage's steps should move the
  // particles even when they did not resample: a model whose static parameters are still being
  // located (its first records) can ask for it, and the moves are then paid where they are cheap.
  virtual bool moves_every_step() const { return false; }
  // The model's own moves that leave π_φ invariant (Gibbs draws, a model-specific MH), by name.
  // None runs unless the sampler's MoveSchedule lists it; the schedule says when.
  virtual std::vector<std::string> model_moves() const { return {}; }

  struct ModelMoveResult {
    bool ran = true;  // false: nothing to move (e.g. no older record yet); recorded as skipped
    double acceptance = std::numeric_limits<double>::quiet_NaN();  // share accepted; NaN for Gibbs
  };
  // Runs model move `move` (an index into model_moves()) once over every particle at φ.
  // run_in_stage counts its earlier runs in this stage (a move may alternate proposals by it).
  // Draw from a child of `rngs` keyed by the move (distinct keys for distinct moves) and per
  // particle i from its stream(i), never from a shared generator, to stay reproducible across
  // thread counts. A move that changes particle i must update log_base[i] and loglik[i].
  virtual ModelMoveResult run_model_move(int move, int /*run_in_stage*/, double /*phi*/, const RngFactory& /*rngs*/,
                                         const ParallelFor& /*parallel*/, Eigen::Ref<Eigen::ArrayXd> /*log_base*/,
                                         Eigen::Ref<Eigen::ArrayXd> /*loglik*/) {
    throw std::logic_error("TemperedModel::run_model_move: model move " + std::to_string(move) +
                           " does not exist (model_moves() lists none)");
  }
};

}  // namespace ssrfleet::smc
