#include "fleet/batch_mcmc_jumps.hpp"

#include <cmath>

#include <boost/random/normal_distribution.hpp>

#include "model/extension_conditionals.hpp"
#include "model/truncated_samplers.hpp"

namespace ssrfleet::fleet::detail {

void LatentJumps::lateral(boost::random::mt19937_64& engine, const HyperVector& theta, const double* psi,
                          Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator,
                          const std::vector<int>& all, bool count, JumpCounts& counts) {
  const Eigen::Index N = latents.rows();
  k_ = latents.col(kStiffness).array();
  kt_ = latents.col(kTyreStiffness).array();
  z_.resize(N);
  for (Eigen::Index n = 0; n < N; ++n) {
    z_[n] = draw_truncated_normal(engine, theta[kZ], theta[kSigmaZ], range_.lo_m, range_.hi_m);
  }
  evaluator.evaluate(all, k_, kt_, z_, psi, ssr_);
  // The prior of z cancels against the proposal: the likelihood ratio decides.
  const double inv2var = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
  for (Eigen::Index n = 0; n < N; ++n) {
    const double log_alpha = -(ssr_[n] - ssr[n]) * inv2var;
    if (std::log(uniform_open01(engine)) < log_alpha) {
      latents(n, kLateral) = z_[n];
      ssr[n] = ssr_[n];
      if (count) ++counts.accepted;
    }
  }
  if (count) counts.tried += N;
}

void LatentJumps::joint(boost::random::mt19937_64& engine, const HyperVector& theta, const double* psi,
                        Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator,
                        bool count, JumpCounts& counts) {
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Index N = latents.rows();
  const bool mixture = edits_stiffness(extension_);
  k_.resize(N);
  kt_.resize(N);
  z_.resize(N);
  valid_.clear();
  for (Eigen::Index n = 0; n < N; ++n) {
    const double u = mixture ? uniform_open01(engine) : 0.0;
    const double k = draw_stiffness(extension_, psi, theta[kK], theta[kSigmaK], u, normal(engine));
    const double kt = theta[kKt] + theta[kSigmaKt] * normal(engine);
    const double z = draw_truncated_normal(engine, theta[kZ], theta[kSigmaZ], range_.lo_m, range_.hi_m);
    // k or k_t <= 0: density 0 (the integrator has no meaning there), rejected unsimulated.
    if (k > 0.0 && kt > 0.0) {
      const auto v = static_cast<Eigen::Index>(valid_.size());
      valid_.push_back(static_cast<int>(n));
      k_[v] = k;
      kt_[v] = kt;
      z_[v] = z;
    }
  }
  const auto V = static_cast<Eigen::Index>(valid_.size());
  if (V > 0) {
    const Eigen::ArrayXd k = k_.head(V), kt = kt_.head(V), z = z_.head(V);
    evaluator.evaluate(valid_, k, kt, z, psi, ssr_);
  }
  const double inv2var = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
  for (Eigen::Index i = 0; i < V; ++i) {
    const int n = valid_[static_cast<std::size_t>(i)];
    const double log_alpha = -(ssr_[i] - ssr[n]) * inv2var;
    if (std::log(uniform_open01(engine)) < log_alpha) {
      latents.row(n) << k_[i], kt_[i], z_[i];
      ssr[n] = ssr_[i];
      if (count) ++counts.accepted;
    }
  }
  if (count) counts.tried += N;
}

}  // namespace ssrfleet::fleet::detail
