// The batch MCMC's (batch_mcmc.hpp, step 5) steps for a model extension: ψ by the extension's jump
// and by an adaptive random walk, and (K, σ_k) by an adaptive random walk when the extension
// replaces the fleet's stiffness distribution. The densities are the ones the latent SMC core uses
// (model/extension_conditionals.hpp); the residuals come through the same extended forward model
// (ResidualEvaluator → model/extended_forward.hpp). Internal to the sampler (namespace detail).
//
// ψ's random walk steps in the extension's move coordinates (ModelExtension::to_move_coordinates;
// profile_defect's straighten its length-height ridge), with their Jacobian in the MH ratio.
//
// Which block moves what (as FleetTarget's moves "extension jump", "extension random walk" and
// "stiffness distribution"):
//   - an extension that edits the forward model: ψ by the jump (if it has one) and the walk, each
//     proposal re-simulating every truck (one batched call of N passes);
//   - one that replaces the stiffness distribution: (K, σ_k) by a walk on log_stiffness_conditional
//     (no Gibbs step: the conditional is not standard), with ψ in the same walk when ψ does not
//     edit the forward model (second_class: then nothing needs simulating, and ψ and (K, σ_k), which
//     the mixture couples, move together);
//   - one that does neither: ψ by the walk against its prior box alone.
// Proposals outside a prior box are rejected without simulating and without drawing a uniform.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <boost/random/mersenne_twister.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_residuals.hpp"
#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"

namespace ssrfleet::fleet::detail {

using McmcEngine = boost::random::mt19937_64;

// A random-walk Metropolis proposal in d dimensions, x' = x + exp(s) L ε with ε ~ N(0, I). In
// burn-in only (the caller stops calling adapt after it, so the kept chain is time-homogeneous):
// s follows a Robbins-Monro recursion towards the target acceptance, and L, first diag(initial_sd),
// becomes 2.38/√d times the Cholesky factor of the chain's own covariance (Roberts, Gelman & Gilks
// 1997) once 200 states are collected, refreshed every 50.
class AdaptiveWalk {
 public:
  AdaptiveWalk(const Eigen::VectorXd& initial_sd, double target_acceptance);
  // Draws d standard normals from engine.
  Eigen::VectorXd propose(McmcEngine& engine, const Eigen::VectorXd& x) const;
  // accept_prob: min(1, α) of the last proposal (0 if it left the box); x: the state after the step,
  // collected when `collect` (burn-in past its transient).
  void adapt(double accept_prob, bool collect, const Eigen::VectorXd& x);

 private:
  Eigen::MatrixXd chol_;
  double log_scale_ = 0.0;
  double target_;
  long long steps_ = 0;
  bool using_chain_covariance_ = false;
  long long count_ = 0;
  Eigen::VectorXd mean_;
  Eigen::MatrixXd m2_;
};

// Where ψ starts when options.initial_psi is not given: the best, by the log posterior given the
// chain's starting θ and latents, of ψ's null value (first) and options.psi_start_candidates points
// of a Halton sequence over ψ's box. A deterministic set, so no random number is drawn and the
// chain's stream is the same as without it. A random walk from the null value alone can stay far
// from a posterior whose ψ the data pin down sharply (profile_defect: at height 0 the position and
// length have no likelihood, so nothing pulls the walk towards the defect; 50 trucks, 25,000 kept
// sweeps: position ESS 6, sigma_IF 14 posterior sd above the SMC's). With an extension that edits
// the forward model every candidate re-simulates every truck (N passes each); ssr follows the
// chosen ψ. With one that only replaces the stiffness distribution, (K, σ_k) join the Halton set
// and 64 times as many candidates are scored (no simulation: N densities each); theta's K and σ_k
// follow the chosen candidate. Returns the number of passes simulated.
long long choose_psi_start(const ModelExtension& extension, const BatchMcmcOptions& options, HyperVector& theta,
                           const Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator,
                           const std::vector<int>& all, std::vector<double>& psi);

class ExtensionSteps {
 public:
  // psi0 inside the extension's box; theta0 the chain's start (it scales the first (K, σ_k) steps).
  ExtensionSteps(const ModelExtension& extension, std::vector<double> psi0, const BatchMcmcOptions& options,
                 const HyperVector& theta0, int trucks);

  const std::vector<double>& psi() const { return psi_; }
  // True when (K, σ_k) move in stiffness_steps instead of their Gibbs step.
  bool moves_stiffness() const { return extension_.edits_stiffness_distribution(); }

  // stiffness_moves_per_sweep MH steps of (K, σ_k[, ψ]) given every truck's k (latents: trucks x 3),
  // after, on sweeps it % psi_jump_every == 0, the extension's stiffness jump if ψ moves here and
  // it has one (counted as the jump's acceptance).
  void stiffness_steps(McmcEngine& engine, int sweep, HyperVector& theta, const Eigen::MatrixXd& latents,
                       bool burning_in, bool collect);
  // The jump (on sweeps it % psi_jump_every == 0, if the extension has one), then psi_moves_per_sweep
  // random-walk steps (unless ψ moves in stiffness_steps). ssr (per truck, at the current ψ) follows
  // an accepted ψ. all: every truck's index.
  void psi_steps(McmcEngine& engine, int sweep, const HyperVector& theta, const Eigen::MatrixXd& latents,
                 Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator, const std::vector<int>& all, bool burning_in,
                 bool collect);
  // Acceptance over the kept sweeps (burning_in false) only.
  double walk_acceptance() const;
  double jump_acceptance() const;
  double stiffness_acceptance() const;

 private:
  // One MH step of ψ to `proposal` given θ and the latents, the proposal's log density ratio
  // (reverse over forward; a move-coordinate Jacobian) added; returns min(1, α) (0 outside the box).
  double try_psi(McmcEngine& engine, const std::vector<double>& proposal, double log_jacobian_ratio,
                 const HyperVector& theta, const Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr,
                 ResidualEvaluator& evaluator, const std::vector<int>& all, long long& accepted);

  const ModelExtension& extension_;
  const BatchMcmcOptions& options_;
  std::vector<double> psi_;
  bool psi_with_stiffness_;  // ψ moves in stiffness_steps (it does not edit the forward model)
  AdaptiveWalk psi_walk_;
  AdaptiveWalk stiffness_walk_;
  Eigen::ArrayXd ssr_proposal_;
  long long walk_tried_ = 0, walk_accepted_ = 0, jump_tried_ = 0, jump_accepted_ = 0, stiffness_tried_ = 0,
            stiffness_accepted_ = 0;
};

}  // namespace ssrfleet::fleet::detail
