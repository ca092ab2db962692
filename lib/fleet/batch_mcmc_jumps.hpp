// The batch MCMC's (batch_mcmc.hpp, step 1) independence jumps of the trucks' latents: proposals
// drawn from the fleet distribution given θ (and ψ), so that the fleet density cancels against the
// proposal's and each truck accepts by its likelihood ratio alone. The random walk explores the
// mode a truck is in; these reach the others:
//   - lateral: z' ~ N(Z, σ_z²) on the road, (k, k_t) kept: a truck's z-likelihood has several
//     peaks across the lane (BatchMcmcOptions::lateral_jump_every);
//   - joint: (k', k_t', z') ~ p(k | K, σ_k, ψ) N(K_t, σ_kt²) N_road(Z, σ_z²): a truck whose
//     likelihood has two (k, k_t, z) modes, e.g. a stiff truck that also fits, softer, on another
//     lateral line, which neither the random walk nor a z-only jump (its k does not fit there)
//     can leave (BatchMcmcOptions::joint_jump_every).
// Each is one batched call of N passes (a proposal with k' or k_t' <= 0 has density 0 and is
// rejected unsimulated). Internal to the sampler (namespace detail).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <boost/random/mersenne_twister.hpp>

#include "fleet/batch_mcmc_residuals.hpp"
#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"

namespace ssrfleet::fleet::detail {

struct JumpCounts {
  long long accepted = 0, tried = 0;  // over trucks, kept sweeps only
  double rate() const { return tried > 0 ? static_cast<double>(accepted) / static_cast<double>(tried) : 0.0; }
};

// latents: trucks x 3 (k, k_t, z); ssr: each truck's sum of squared residuals, both updated where a
// truck accepts. all: every truck's index. psi: the extension's parameters (null without one).
// counts gains the trucks' tries and acceptances when `count` (kept sweeps).
class LatentJumps {
 public:
  LatentJumps(const ModelExtension* extension, const LateralRange& range)
      : extension_(extension), range_(range) {}

  // Draws N truncated normals, then N uniforms, from engine, in truck order.
  void lateral(boost::random::mt19937_64& engine, const HyperVector& theta, const double* psi,
               Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator,
               const std::vector<int>& all, bool count, JumpCounts& counts);
  // Per truck in order: (with an extension's stiffness distribution) a uniform, then normals for k
  // and k_t and a truncated normal for z; then a uniform for each truck whose proposal is simulated.
  void joint(boost::random::mt19937_64& engine, const HyperVector& theta, const double* psi,
             Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator, bool count,
             JumpCounts& counts);

 private:
  const ModelExtension* extension_;
  LateralRange range_;
  Eigen::ArrayXd k_, kt_, z_, ssr_;
  std::vector<int> valid_;
};

}  // namespace ssrfleet::fleet::detail
