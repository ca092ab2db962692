// The fleet model with a model extension (model_extension.hpp) over many trucks: the densities
// that an extension's parameters ψ change, in one place for every sampler that keeps the latents.
// The latent SMC core (FleetTarget) and the batch MCMC call these; neither writes its own.
//
// An extension changes the posterior in at most two ways:
//  - through the forward model (edits_forward): every truck's residuals depend on ψ, so a ψ step
//    compares the sums of squared residuals at ψ and ψ' (extended_forward.hpp simulates them);
//  - through the fleet's stiffness distribution (edits_stiffness_distribution): k ~ p(k | K, σ_k, ψ)
//    replaces N(K, σ_k²). That density has no sufficient statistic, so its sums run over every
//    truck's k, and (K, σ_k) lose their conjugate conditionals (fleet_conditionals.hpp): they move
//    by MH on log_stiffness_conditional below.
// The uniform prior of ψ is constant inside its box, so it enters only as the box.
#pragma once

#include <limits>

#include <Eigen/Core>

#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"

namespace ssrfleet::fleet {

// Whether the extension replaces the base model's N(K, σ_k²) (a null extension does not).
inline bool edits_stiffness(const ModelExtension* extension) {
  return extension != nullptr && extension->edits_stiffness_distribution();
}

// log p(k | K, σ_k, ψ): the base model's N(K, σ_k²), or the extension's stiffness density.
inline double log_stiffness_density(const ModelExtension* extension, const double* psi, double stiffness_npm,
                                    double mean_npm, double sd_npm) {
  return edits_stiffness(extension) ? extension->log_stiffness_density(psi, stiffness_npm, mean_npm, sd_npm)
                                    : log_normal_density(stiffness_npm, mean_npm, sd_npm);
}

// A truck's k drawn from p(k | K, σ_k, ψ) from a uniform on [0, 1) and an independent standard
// normal: the base model's K + σ_k ε (the uniform unused), or the extension's draw.
inline double draw_stiffness(const ModelExtension* extension, const double* psi, double mean_npm, double sd_npm,
                             double uniform, double standard_normal) {
  return edits_stiffness(extension) ? extension->draw_stiffness(psi, mean_npm, sd_npm, uniform, standard_normal)
                                    : mean_npm + sd_npm * standard_normal;
}

// log p(k, k_t, z | θ, ψ) of one truck: the base model's density, with the extension's stiffness
// density for the k factor when it has one. Without one (or a null extension) it is exactly
// log_latent_density; with one at its null ψ it is too, whenever the extension's density returns
// the base density's bits there (second_class at share 0 does).
inline double log_latent_density(const ModelExtension* extension, const double* psi, double stiffness_npm,
                                 double tyre_stiffness_npm, double lateral_m, const HyperVector& theta,
                                 const LateralRange& range) {
  if (!edits_stiffness(extension)) {
    return log_latent_density(stiffness_npm, tyre_stiffness_npm, lateral_m, theta, range);
  }
  return log_latent_density_with_stiffness_term(
      log_stiffness_density(extension, psi, stiffness_npm, theta[kK], theta[kSigmaK]), tyre_stiffness_npm, lateral_m,
      theta, range);
}

// Σ_j log p(k_j | mean, sd, ψ) over n trucks' stiffnesses k[0], k[stride], ..., k[(n-1) stride],
// summed in truck order.
inline double log_stiffness_sum(const ModelExtension& extension, const double* psi, const double* k, Eigen::Index n,
                                Eigen::Index stride, double mean_npm, double sd_npm) {
  double lp = 0.0;
  for (Eigen::Index j = 0; j < n; ++j) lp += extension.log_stiffness_density(psi, k[j * stride], mean_npm, sd_npm);
  return lp;
}

// log p(K, σ_k, ψ | k_1..n) up to a constant, for an extension's stiffness distribution: the
// uniform boxes of K, σ_k (prior) and ψ, and the trucks' stiffness densities. -inf outside a box.
inline double log_stiffness_conditional(const ModelExtension& extension, double mean_npm, double sd_npm,
                                        const double* psi, const double* k, Eigen::Index n, Eigen::Index stride,
                                        const PriorBounds& prior) {
  if (!(mean_npm >= prior.lo[kK] && mean_npm <= prior.hi[kK] && sd_npm >= prior.lo[kSigmaK] &&
        sd_npm <= prior.hi[kSigmaK]) ||
      !extension.in_prior(psi)) {
    return -std::numeric_limits<double>::infinity();
  }
  return log_stiffness_sum(extension, psi, k, n, stride, mean_npm, sd_npm);
}

// log of the MH ratio p(ψ' | ...) / p(ψ | ...) given θ and every truck's latents, for a proposal
// inside ψ's box (the uniform prior cancels): the likelihood ratio from the trucks' total sums of
// squared residuals at ψ' and ψ (equal when the extension does not edit the forward model), plus,
// with an extension's stiffness distribution, the ratio of the trucks' stiffness densities.
inline double log_psi_ratio(const ModelExtension& extension, const double* psi_new, const double* psi_old,
                            double ssr_new, double ssr_old, double sigma_if, const double* k, Eigen::Index n,
                            Eigen::Index stride, double mean_npm, double sd_npm) {
  double log_ratio = (ssr_old - ssr_new) / (2.0 * sigma_if * sigma_if);
  if (extension.edits_stiffness_distribution()) {
    log_ratio += log_stiffness_sum(extension, psi_new, k, n, stride, mean_npm, sd_npm) -
                 log_stiffness_sum(extension, psi_old, k, n, stride, mean_npm, sd_npm);
  }
  return log_ratio;
}

}  // namespace ssrfleet::fleet
