#include "fleet/batch_mcmc_extension.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include <Eigen/Cholesky>
#include <boost/random/normal_distribution.hpp>

#include "model/extension_conditionals.hpp"
#include "model/truncated_samplers.hpp"

namespace ssrfleet::fleet::detail {

namespace {
constexpr long long kMomentsBeforeShape = 200;  // chain states before its covariance shapes the walk
constexpr long long kShapeEvery = 50;            // states between refreshes of that shape
// Start candidates that need no simulation (see choose_psi_start), per psi_start_candidates.
constexpr long long kFreeCandidateFactor = 64;

double rate(long long accepted, long long tried) {
  return tried > 0 ? static_cast<double>(accepted) / static_cast<double>(tried) : 0.0;
}
}  // namespace

AdaptiveWalk::AdaptiveWalk(const Eigen::VectorXd& initial_sd, double target_acceptance)
    : chol_(initial_sd.asDiagonal()), target_(target_acceptance), mean_(Eigen::VectorXd::Zero(initial_sd.size())),
      m2_(Eigen::MatrixXd::Zero(initial_sd.size(), initial_sd.size())) {}

Eigen::VectorXd AdaptiveWalk::propose(McmcEngine& engine, const Eigen::VectorXd& x) const {
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd eps(x.size());
  for (Eigen::Index j = 0; j < x.size(); ++j) eps[j] = normal(engine);
  return x + std::exp(log_scale_) * (chol_ * eps);
}

void AdaptiveWalk::adapt(double accept_prob, bool collect, const Eigen::VectorXd& x) {
  ++steps_;
  // The same gain sequence as the sampler's other walks (batch_mcmc.cpp): large moves early, then
  // a decreasing correction.
  const double gain = std::min(1.0, 3.0 * std::pow(static_cast<double>(steps_), -0.6));
  log_scale_ = std::clamp(log_scale_ + gain * (accept_prob - target_), -15.0, 5.0);
  if (!collect) return;
  ++count_;
  const Eigen::VectorXd delta = x - mean_;
  mean_ += delta / static_cast<double>(count_);
  m2_ += delta * (x - mean_).transpose();
  if (count_ < kMomentsBeforeShape || count_ % kShapeEvery != 0) return;
  Eigen::MatrixXd cov = m2_ / static_cast<double>(count_ - 1);
  const Eigen::VectorXd var = cov.diagonal();
  if (!(var.array() > 0.0).all()) return;  // a coordinate that has not moved yet keeps its first step
  cov.diagonal() += 1e-6 * var;             // keeps the factor well conditioned
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  if (llt.info() != Eigen::Success) return;
  chol_ = 2.38 / std::sqrt(static_cast<double>(x.size())) * Eigen::MatrixXd(llt.matrixL());
  if (!using_chain_covariance_) {
    // The first switch from the generic diagonal: restart the scale at the optimal one for the shape.
    using_chain_covariance_ = true;
    log_scale_ = 0.0;
  }
}

namespace {
// The walk's first step per coordinate of ψ's move coordinates (ModelExtension::to_move_coordinates):
// `fraction` of how far that coordinate moves across ψ_j's box with the others at their null values
// (for ψ itself, of the box's width).
Eigen::VectorXd psi_initial_sd(const ModelExtension& extension, double fraction) {
  const std::vector<double> spans = extension.move_coordinate_spans();
  Eigen::VectorXd sd(extension.dim());
  for (Eigen::Index j = 0; j < sd.size(); ++j) sd[j] = fraction * spans[static_cast<std::size_t>(j)];
  return sd;
}

// (K, σ_k) first: the scale of their conditional given N trucks' k (K: σ_k/√N; σ_k: σ_k/√(2N)); then ψ.
Eigen::VectorXd stiffness_initial_sd(const ModelExtension& extension, bool with_psi, double fraction,
                                     const HyperVector& theta, int trucks) {
  const double n = static_cast<double>(trucks);
  const Eigen::VectorXd psi_sd = psi_initial_sd(extension, fraction);
  Eigen::VectorXd sd(2 + (with_psi ? psi_sd.size() : 0));
  sd[0] = theta[kSigmaK] / std::sqrt(n);
  sd[1] = theta[kSigmaK] / std::sqrt(2.0 * n);
  if (with_psi) sd.tail(psi_sd.size()) = psi_sd;
  return sd;
}
}  // namespace

namespace {
// The radical inverse of i in base b (the i-th point of the van der Corput sequence).
double radical_inverse(long long i, int base) {
  double inverse = 1.0 / base, value = 0.0, digit_scale = inverse;
  for (; i > 0; i /= base) {
    value += static_cast<double>(i % base) * digit_scale;
    digit_scale *= inverse;
  }
  return value;
}
}  // namespace

long long choose_psi_start(const ModelExtension& extension, const BatchMcmcOptions& options, HyperVector& theta,
                           const Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator,
                           const std::vector<int>& all, std::vector<double>& psi) {
  static constexpr int kPrimes[] = {2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37};
  const bool forward = extension.edits_forward();
  // With an extension's stiffness distribution and no forward edit (second_class), the candidates
  // cost no simulation, and (K, σ_k) vary with ψ: scored at the start's (K, σ_k), a two-class ψ
  // names the majority as the second class (share near 0.5, K2 at the bulk of the trucks, the first
  // class broad over the stiff ones), a local mode that a random walk does not leave (50 trucks,
  // 16 of them stiff: K2 486k against 982k from the true ψ, 5 nats lower in mean log target).
  const bool with_stiffness = extension.edits_stiffness_distribution() && !forward;
  const auto d_psi = static_cast<std::size_t>(extension.dim());
  const std::size_t d = d_psi + (with_stiffness ? 2 : 0);
  if (d_psi == 0 || d > std::size(kPrimes)) return 0;  // nothing to choose, or no Halton bases for so many  // no Halton bases for so many parameters: keep the start
  // Free candidates are many more: they only sum N stiffness densities each.
  const long long candidates =
      static_cast<long long>(options.psi_start_candidates) * (with_stiffness ? kFreeCandidateFactor : 1);
  const double* k = latents.col(kStiffness).data();
  const double inv2var = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
  const auto& prior = options.prior;
  // log p(ψ[, K, σ_k] | the rest, data) up to a constant (the boxes are uniform).
  const auto score = [&](const std::vector<double>& candidate, double mean, double sd, double total_ssr) {
    double lp = -total_ssr * inv2var;
    if (extension.edits_stiffness_distribution()) {
      lp += log_stiffness_sum(extension, candidate.data(), k, latents.rows(), 1, mean, sd);
    }
    return lp;
  };
  double best = score(psi, theta[kK], theta[kSigmaK], ssr.sum());
  long long passes = 0;
  std::vector<double> candidate(d_psi);
  Eigen::ArrayXd candidate_ssr;
  for (long long c = 1; c <= candidates; ++c) {
    for (std::size_t j = 0; j < d_psi; ++j) {
      const auto& p = extension.parameters()[j];
      candidate[j] = p.lo + (p.hi - p.lo) * radical_inverse(c, kPrimes[j]);
    }
    double mean = theta[kK], sd = theta[kSigmaK];
    if (with_stiffness) {
      mean = prior.lo[kK] + (prior.hi[kK] - prior.lo[kK]) * radical_inverse(c, kPrimes[d_psi]);
      sd = prior.lo[kSigmaK] + (prior.hi[kSigmaK] - prior.lo[kSigmaK]) * radical_inverse(c, kPrimes[d_psi + 1]);
    }
    double total = ssr.sum();
    if (forward) {
      evaluator.evaluate(all, latents.col(kStiffness).array(), latents.col(kTyreStiffness).array(),
                         latents.col(kLateral).array(), candidate.data(), candidate_ssr);
      passes += latents.rows();
      total = candidate_ssr.sum();
    }
    const double lp = score(candidate, mean, sd, total);
    if (std::isfinite(lp) && lp > best) {
      best = lp;
      psi = candidate;
      if (with_stiffness) {
        theta[kK] = mean;
        theta[kSigmaK] = sd;
      }
      if (forward) ssr = candidate_ssr;
    }
  }
  return passes;
}

ExtensionSteps::ExtensionSteps(const ModelExtension& extension, std::vector<double> psi0,
                               const BatchMcmcOptions& options, const HyperVector& theta0, int trucks)
    : extension_(extension), options_(options), psi_(std::move(psi0)),
      psi_with_stiffness_(extension.edits_stiffness_distribution() && !extension.edits_forward()),
      psi_walk_(psi_initial_sd(extension, options.psi_initial_step), options.target_acceptance),
      stiffness_walk_(stiffness_initial_sd(extension, psi_with_stiffness_, options.psi_initial_step, theta0, trucks),
                      options.target_acceptance) {}

void ExtensionSteps::stiffness_steps(McmcEngine& engine, int sweep, HyperVector& theta,
                                     const Eigen::MatrixXd& latents, bool burning_in, bool collect) {
  const Eigen::Index n = latents.rows(), d_psi = psi_with_stiffness_ ? extension_.dim() : 0;
  const double* k = latents.col(kStiffness).data();
  Eigen::VectorXd x(2 + d_psi);
  x[0] = theta[kK];
  x[1] = theta[kSigmaK];
  for (Eigen::Index j = 0; j < d_psi; ++j) x[2 + j] = psi_[static_cast<std::size_t>(j)];
  const auto log_density = [&](const Eigen::VectorXd& y) {
    return log_stiffness_conditional(extension_, y[0], y[1], psi_with_stiffness_ ? y.data() + 2 : psi_.data(), k, n,
                                     1, options_.prior);
  };
  double current = log_density(x);
  // The extension's jump of (K, σ_k, ψ) (second_class: the classes trade places), before the walk.
  if (psi_with_stiffness_ && extension_.stiffness_jump_draws() > 0 && options_.psi_jump_every > 0 &&
      sweep % options_.psi_jump_every == 0) {
    std::vector<double> u(static_cast<std::size_t>(extension_.stiffness_jump_draws()));
    for (double& v : u) v = uniform_open01(engine);
    Eigen::VectorXd y(x.size());
    extension_.stiffness_jump(x.data() + 2, x[0], x[1], u.data(), y.data() + 2, &y[0], &y[1]);
    const double candidate = log_density(y);
    if (std::isfinite(candidate) && std::log(uniform_open01(engine)) < candidate - current) {
      x = y;
      current = candidate;
      if (!burning_in) ++jump_accepted_;
    }
    if (!burning_in) ++jump_tried_;
  }
  for (int s = 0; s < options_.stiffness_moves_per_sweep; ++s) {
    const Eigen::VectorXd y = stiffness_walk_.propose(engine, x);
    const double candidate = log_density(y);
    double accept_prob = 0.0;
    if (std::isfinite(candidate)) {  // outside a box: rejected, no uniform drawn
      const double log_alpha = candidate - current;
      accept_prob = std::min(1.0, std::exp(log_alpha));
      if (std::log(uniform_open01(engine)) < log_alpha) {
        x = y;
        current = candidate;
        if (!burning_in) ++stiffness_accepted_;
      }
    }
    if (!burning_in) ++stiffness_tried_;
    if (burning_in) stiffness_walk_.adapt(accept_prob, collect, x);
  }
  theta[kK] = x[0];
  theta[kSigmaK] = x[1];
  for (Eigen::Index j = 0; j < d_psi; ++j) psi_[static_cast<std::size_t>(j)] = x[2 + j];
}

double ExtensionSteps::try_psi(McmcEngine& engine, const std::vector<double>& proposal, double log_jacobian_ratio,
                               const HyperVector& theta, const Eigen::MatrixXd& latents, Eigen::ArrayXd& ssr,
                               ResidualEvaluator& evaluator, const std::vector<int>& all, long long& accepted) {
  if (!extension_.in_prior(proposal.data())) return 0.0;
  const bool forward = extension_.edits_forward();
  const double ssr_now = ssr.sum();
  double ssr_new = ssr_now;
  if (forward) {
    evaluator.evaluate(all, latents.col(kStiffness).array(), latents.col(kTyreStiffness).array(),
                       latents.col(kLateral).array(), proposal.data(), ssr_proposal_);
    ssr_new = ssr_proposal_.sum();
    if (!std::isfinite(ssr_new)) return 0.0;  // a truck the integrator cannot run at ψ': density 0
  }
  const double log_alpha =
      log_psi_ratio(extension_, proposal.data(), psi_.data(), ssr_new, ssr_now, theta[kSigmaIf],
                    latents.col(kStiffness).data(), latents.rows(), 1, theta[kK], theta[kSigmaK]) +
      log_jacobian_ratio;
  const double accept_prob = std::isfinite(log_alpha) ? std::min(1.0, std::exp(log_alpha)) : 0.0;
  if (std::log(uniform_open01(engine)) < log_alpha) {
    psi_ = proposal;
    if (forward) ssr = ssr_proposal_;
    ++accepted;
  }
  return accept_prob;
}

void ExtensionSteps::psi_steps(McmcEngine& engine, int sweep, const HyperVector& theta, const Eigen::MatrixXd& latents,
                               Eigen::ArrayXd& ssr, ResidualEvaluator& evaluator, const std::vector<int>& all,
                               bool burning_in, bool collect) {
  if (extension_.dim() == 0) return;  // every parameter fixed by the model spec
  long long discard = 0;
  if (extension_.jump_draws() > 0 && options_.psi_jump_every > 0 && sweep % options_.psi_jump_every == 0) {
    std::vector<double> u(static_cast<std::size_t>(extension_.jump_draws())), proposal(psi_.size());
    for (double& v : u) v = uniform_open01(engine);
    extension_.jump(psi_.data(), u.data(), proposal.data());
    try_psi(engine, proposal, 0.0, theta, latents, ssr, evaluator, all, burning_in ? discard : jump_accepted_);
    if (!burning_in) ++jump_tried_;
  }
  if (psi_with_stiffness_) return;  // ψ moved with (K, σ_k) in stiffness_steps
  // The walk steps in the extension's move coordinates u (the identity unless it defines them):
  // its target there is π(ψ(u)) |det ∂ψ/∂u|, hence the Jacobian ratio.
  const Eigen::Index d = extension_.dim();
  Eigen::VectorXd x(d);
  std::vector<double> proposal(static_cast<std::size_t>(d));
  for (int s = 0; s < options_.psi_moves_per_sweep; ++s) {
    extension_.to_move_coordinates(psi_.data(), x.data());
    const Eigen::VectorXd y = psi_walk_.propose(engine, x);
    extension_.from_move_coordinates(y.data(), proposal.data());
    const double log_jacobian_ratio =
        extension_.in_prior(proposal.data())
            ? extension_.log_move_jacobian(proposal.data()) - extension_.log_move_jacobian(psi_.data())
            : 0.0;
    const double accept_prob = try_psi(engine, proposal, log_jacobian_ratio, theta, latents, ssr, evaluator, all,
                                       burning_in ? discard : walk_accepted_);
    if (!burning_in) ++walk_tried_;
    if (burning_in) {
      extension_.to_move_coordinates(psi_.data(), x.data());
      psi_walk_.adapt(accept_prob, collect, x);
    }
  }
}

double ExtensionSteps::walk_acceptance() const {
  return psi_with_stiffness_ ? stiffness_acceptance() : rate(walk_accepted_, walk_tried_);
}
double ExtensionSteps::jump_acceptance() const { return rate(jump_accepted_, jump_tried_); }
double ExtensionSteps::stiffness_acceptance() const { return rate(stiffness_accepted_, stiffness_tried_); }

}  // namespace ssrfleet::fleet::detail
