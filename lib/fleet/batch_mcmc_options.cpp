// BatchMcmcOptions::IsValid (rules a user can read in the message) and the batch MCMC's log
// posterior (batch_mcmc.hpp), apart from the chain that uses them.
#include "fleet/batch_mcmc.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "model/extension_conditionals.hpp"
#include "util/option_rules.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
}  // namespace

bool BatchMcmcOptions::IsValid(std::string* error) const {
  // A failed rule returns at once: later rules may read what an earlier one checked (extension).
  util::OptionRules rules("BatchMcmcOptions", error);
  if (!rules.require(iterations >= 1, "iterations", iterations, ">= 1")) return false;
  if (!rules.require(burn_in >= 0, "burn_in", burn_in, ">= 0")) return false;
  if (!rules.require(burn_in < iterations, "burn_in", burn_in,
                        "< iterations (" + std::to_string(iterations) + "), or no draw is kept")) return false;
  if (!rules.require(thin >= 1, "thin", thin, ">= 1")) return false;
  if (!rules.require(start_dispersion >= 0.0 && start_dispersion <= 10.0, "start_dispersion", start_dispersion,
                        "in [0, 10]")) return false;
  if (!rules.require(target_acceptance > 0.0 && target_acceptance < 1.0, "target_acceptance",
                        target_acceptance, "in (0, 1)")) return false;
  if (!rules.require(z_moves_per_sweep >= 1, "z_moves_per_sweep", z_moves_per_sweep, ">= 1")) return false;
  if (!rules.require(std::isfinite(init_grid_step_m) && init_grid_step_m > 0.0, "init_grid_step_m",
                        init_grid_step_m, "positive")) return false;
  if (!rules.require(hold_theta_sweeps >= 0, "hold_theta_sweeps", hold_theta_sweeps, ">= 0")) return false;
  if (!rules.require(progress_every >= 0, "progress_every", progress_every, ">= 0")) return false;
  for (int j = 0; j < kHyperCount; ++j) {
    const std::string name = "prior bounds of " + std::string(kHyperNames[static_cast<std::size_t>(j)]);
    std::ostringstream value;
    value << "[" << prior.lo[static_cast<std::size_t>(j)] << ", " << prior.hi[static_cast<std::size_t>(j)]
          << "]";
    if (!rules.require(std::isfinite(prior.lo[static_cast<std::size_t>(j)]) &&
                              std::isfinite(prior.hi[static_cast<std::size_t>(j)]) &&
                              prior.lo[static_cast<std::size_t>(j)] < prior.hi[static_cast<std::size_t>(j)],
                          name, value.str(), "a finite interval with lo < hi")) return false;
  }
  for (int j : {kSigmaK, kSigmaKt, kSigmaZ, kSigmaIf}) {
    const std::string name = "lower prior bound of " + std::string(kHyperNames[static_cast<std::size_t>(j)]);
    if (!rules.require(prior.lo[static_cast<std::size_t>(j)] > 0.0, name,
                          prior.lo[static_cast<std::size_t>(j)], "positive (a scale)")) return false;
  }
  if (initial_theta) {
    if (!rules.require(prior.contains(*initial_theta), "initial_theta", "(outside the prior box)",
                          "inside the prior box")) return false;
  }
  if (initial_latents) {
    if (!rules.require(initial_latents->cols() == kLatentCount, "initial_latents columns",
                          initial_latents->cols(), "3 (k, kt, z)")) return false;
    if (!rules.require(initial_latents->allFinite(), "initial_latents", "(not all finite)", "finite")) return false;
  }
  if (!rules.require(!freeze_latents || initial_latents.has_value(), "freeze_latents", "true",
                        "false unless initial_latents is given")) return false;
  if (!rules.require(ancillary_steps >= 1, "ancillary_steps", ancillary_steps, ">= 1")) return false;
  if (!rules.require(ancillary_every >= 1, "ancillary_every", ancillary_every, ">= 1")) return false;
  if (!rules.require(lateral_jump_every >= 0, "lateral_jump_every", lateral_jump_every, ">= 0")) return false;
  if (!rules.require(joint_jump_every >= 0, "joint_jump_every", joint_jump_every, ">= 0 (0 = no joint jumps)")) return false;
  if (!rules.require(threads >= 0, "threads", threads, ">= 0 (0 = all hardware threads)")) return false;
  if (!rules.require(psi_moves_per_sweep >= 1, "psi_moves_per_sweep", psi_moves_per_sweep, ">= 1")) return false;
  if (!rules.require(psi_jump_every >= 0, "psi_jump_every", psi_jump_every, ">= 0 (0 = no jumps)")) return false;
  if (!rules.require(std::isfinite(psi_initial_step) && psi_initial_step > 0.0 && psi_initial_step <= 1.0,
                        "psi_initial_step", psi_initial_step, "in (0, 1] (a fraction of each prior width)")) return false;
  if (!rules.require(stiffness_moves_per_sweep >= 1, "stiffness_moves_per_sweep", stiffness_moves_per_sweep,
                        ">= 1")) return false;
  if (!rules.require(psi_start_candidates >= 0, "psi_start_candidates", psi_start_candidates, ">= 0")) return false;
  if (initial_psi) {
    if (!rules.require(extension != nullptr, "initial_psi", "given", "absent without an extension")) return false;
    if (!rules.require(static_cast<Eigen::Index>(initial_psi->size()) == extension->dim(), "initial_psi size",
                          initial_psi->size(),
                          std::to_string(extension->dim()) + " (the parameters of " + extension->name() + ")")) return false;
    if (!rules.require(extension->in_prior(initial_psi->data()), "initial_psi", "(outside the prior box)",
                          "inside the prior box of " + extension->name())) return false;
  }
  // The ancillary (K, sigma_k) step standardises k by N(K, sigma_k^2) (batch_mcmc_interweave.hpp):
  // with another stiffness distribution its target would be wrong.
  if (!rules.require(!(interweave && interweave_stiffness && extension != nullptr &&
                          extension->edits_stiffness_distribution()),
                        "interweave_stiffness", "true",
                        "false with an extension that replaces the stiffness distribution (" +
                            (extension != nullptr ? extension->name() : std::string()) + ")")) return false;
  return rules.passed();
}

double log_posterior_unnormalised(const HyperVector& theta, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                                  const Eigen::Ref<const Eigen::VectorXd>& ssr, int sensors,
                                  const PriorBounds& prior, const LateralRange& range) {
  return log_posterior_unnormalised(theta, latents, ssr, sensors, prior, range, nullptr, nullptr);
}

double log_posterior_unnormalised(const HyperVector& theta, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                                  const Eigen::Ref<const Eigen::VectorXd>& ssr, int sensors,
                                  const PriorBounds& prior, const LateralRange& range,
                                  const ModelExtension* extension, const double* psi) {
  double lp = prior.log_prior(theta);
  if (!std::isfinite(lp)) return kNegInf;
  for (Eigen::Index n = 0; n < latents.rows(); ++n) {
    lp += log_latent_density(extension, psi, latents(n, kStiffness), latents(n, kTyreStiffness),
                             latents(n, kLateral), theta, range);
    lp += log_likelihood_from_ssr(ssr[n], sensors, theta[kSigmaIf]);
  }
  // Added last, so the extension at its null ψ differs from the base model by exactly this term.
  if (extension != nullptr) lp += extension->log_prior(psi);
  return lp;
}

}  // namespace ssrfleet::fleet
