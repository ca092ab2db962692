// BatchMcmcOptions::IsValid (rules a user can read in the message) and the batch MCMC's log
// posterior (batch_mcmc.hpp), apart from the chain that uses them.
#include "fleet/batch_mcmc.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "model/extension_conditionals.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
}  // namespace

#define SSRFLEET_OPTION_CHECK(cond, name, value, rule)                                       \
  do {                                                                                       \
    if (!(cond)) {                                                                           \
      if (error) {                                                                           \
        std::ostringstream os;                                                               \
        os << "BatchMcmcOptions: " << name << " is " << (value) << ", but must be " << rule; \
        *error = os.str();                                                                   \
      }                                                                                      \
      return false;                                                                          \
    }                                                                                        \
  } while (false)

bool BatchMcmcOptions::IsValid(std::string* error) const {
  SSRFLEET_OPTION_CHECK(iterations >= 1, "iterations", iterations, ">= 1");
  SSRFLEET_OPTION_CHECK(burn_in >= 0, "burn_in", burn_in, ">= 0");
  SSRFLEET_OPTION_CHECK(burn_in < iterations, "burn_in", burn_in,
                        "< iterations (" + std::to_string(iterations) + "), or no draw is kept");
  SSRFLEET_OPTION_CHECK(thin >= 1, "thin", thin, ">= 1");
  SSRFLEET_OPTION_CHECK(start_dispersion >= 0.0 && start_dispersion <= 10.0, "start_dispersion", start_dispersion,
                        "in [0, 10]");
  SSRFLEET_OPTION_CHECK(target_acceptance > 0.0 && target_acceptance < 1.0, "target_acceptance",
                        target_acceptance, "in (0, 1)");
  SSRFLEET_OPTION_CHECK(z_moves_per_sweep >= 1, "z_moves_per_sweep", z_moves_per_sweep, ">= 1");
  SSRFLEET_OPTION_CHECK(std::isfinite(init_grid_step_m) && init_grid_step_m > 0.0, "init_grid_step_m",
                        init_grid_step_m, "positive");
  SSRFLEET_OPTION_CHECK(hold_theta_sweeps >= 0, "hold_theta_sweeps", hold_theta_sweeps, ">= 0");
  SSRFLEET_OPTION_CHECK(progress_every >= 0, "progress_every", progress_every, ">= 0");
  for (int j = 0; j < kHyperCount; ++j) {
    const std::string name = "prior bounds of " + std::string(kHyperNames[static_cast<std::size_t>(j)]);
    std::ostringstream value;
    value << "[" << prior.lo[static_cast<std::size_t>(j)] << ", " << prior.hi[static_cast<std::size_t>(j)]
          << "]";
    SSRFLEET_OPTION_CHECK(std::isfinite(prior.lo[static_cast<std::size_t>(j)]) &&
                              std::isfinite(prior.hi[static_cast<std::size_t>(j)]) &&
                              prior.lo[static_cast<std::size_t>(j)] < prior.hi[static_cast<std::size_t>(j)],
                          name, value.str(), "a finite interval with lo < hi");
  }
  for (int j : {kSigmaK, kSigmaKt, kSigmaZ, kSigmaIf}) {
    const std::string name = "lower prior bound of " + std::string(kHyperNames[static_cast<std::size_t>(j)]);
    SSRFLEET_OPTION_CHECK(prior.lo[static_cast<std::size_t>(j)] > 0.0, name,
                          prior.lo[static_cast<std::size_t>(j)], "positive (a scale)");
  }
  if (initial_theta) {
    SSRFLEET_OPTION_CHECK(prior.contains(*initial_theta), "initial_theta", "(outside the prior box)",
                          "inside the prior box");
  }
  if (initial_latents) {
    SSRFLEET_OPTION_CHECK(initial_latents->cols() == kLatentCount, "initial_latents columns",
                          initial_latents->cols(), "3 (k, kt, z)");
    SSRFLEET_OPTION_CHECK(initial_latents->allFinite(), "initial_latents", "(not all finite)", "finite");
  }
  SSRFLEET_OPTION_CHECK(!freeze_latents || initial_latents.has_value(), "freeze_latents", "true",
                        "false unless initial_latents is given");
  SSRFLEET_OPTION_CHECK(ancillary_steps >= 1, "ancillary_steps", ancillary_steps, ">= 1");
  SSRFLEET_OPTION_CHECK(ancillary_every >= 1, "ancillary_every", ancillary_every, ">= 1");
  SSRFLEET_OPTION_CHECK(lateral_jump_every >= 0, "lateral_jump_every", lateral_jump_every, ">= 0");
  SSRFLEET_OPTION_CHECK(joint_jump_every >= 0, "joint_jump_every", joint_jump_every, ">= 0 (0 = no joint jumps)");
  SSRFLEET_OPTION_CHECK(threads >= 0, "threads", threads, ">= 0 (0 = all hardware threads)");
  SSRFLEET_OPTION_CHECK(psi_moves_per_sweep >= 1, "psi_moves_per_sweep", psi_moves_per_sweep, ">= 1");
  SSRFLEET_OPTION_CHECK(psi_jump_every >= 0, "psi_jump_every", psi_jump_every, ">= 0 (0 = no jumps)");
  SSRFLEET_OPTION_CHECK(std::isfinite(psi_initial_step) && psi_initial_step > 0.0 && psi_initial_step <= 1.0,
                        "psi_initial_step", psi_initial_step, "in (0, 1] (a fraction of each prior width)");
  SSRFLEET_OPTION_CHECK(stiffness_moves_per_sweep >= 1, "stiffness_moves_per_sweep", stiffness_moves_per_sweep,
                        ">= 1");
  SSRFLEET_OPTION_CHECK(psi_start_candidates >= 0, "psi_start_candidates", psi_start_candidates, ">= 0");
  if (initial_psi) {
    SSRFLEET_OPTION_CHECK(extension != nullptr, "initial_psi", "given", "absent without an extension");
    SSRFLEET_OPTION_CHECK(static_cast<Eigen::Index>(initial_psi->size()) == extension->dim(), "initial_psi size",
                          initial_psi->size(),
                          std::to_string(extension->dim()) + " (the parameters of " + extension->name() + ")");
    SSRFLEET_OPTION_CHECK(extension->in_prior(initial_psi->data()), "initial_psi", "(outside the prior box)",
                          "inside the prior box of " + extension->name());
  }
  // The ancillary (K, sigma_k) step standardises k by N(K, sigma_k^2) (batch_mcmc_interweave.hpp):
  // with another stiffness distribution its target would be wrong.
  SSRFLEET_OPTION_CHECK(!(interweave && interweave_stiffness && extension != nullptr &&
                          extension->edits_stiffness_distribution()),
                        "interweave_stiffness", "true",
                        "false with an extension that replaces the stiffness distribution (" +
                            (extension != nullptr ? extension->name() : std::string()) + ")");
  return true;
}

#undef SSRFLEET_OPTION_CHECK

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
