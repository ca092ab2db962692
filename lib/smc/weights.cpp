#include "smc/weights.hpp"

#include <cmath>
#include <limits>

#include "util/errors.hpp"

namespace ssrfleet::smc {

namespace {
constexpr double kMinusInf = -std::numeric_limits<double>::infinity();
}

double log_sum_exp(const Eigen::Ref<const Eigen::ArrayXd>& a) {
  if (a.size() == 0) return kMinusInf;
  const double m = a.maxCoeff();
  if (m == kMinusInf) return kMinusInf;
  if (!std::isfinite(m)) return m;  // +inf or NaN propagate
  return m + std::log((a - m).exp().sum());
}

Eigen::ArrayXd normalised_weights(const Eigen::Ref<const Eigen::ArrayXd>& logw) {
  const double lse = log_sum_exp(logw);
  if (!std::isfinite(lse))
    throw NumericalError("normalised_weights: the log weights sum to " + std::to_string(lse) +
                         " (every weight zero, or a NaN or +inf weight)");
  return (logw - lse).exp();
}

double effective_sample_size(const Eigen::Ref<const Eigen::ArrayXd>& W) {
  const double s = W.sum();
  return s * s / W.square().sum();
}

Eigen::ArrayXd log_increment(const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta) {
  if (delta == 0.0) return Eigen::ArrayXd::Zero(loglik.size());
  return delta * loglik;
}

double relative_conditional_ess(const Eigen::Ref<const Eigen::ArrayXd>& W,
                                const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta) {
  const Eigen::ArrayXd logW = W.log();  // zero weights give -inf, harmless below
  const Eigen::ArrayXd v = log_increment(loglik, delta);
  // (Σ W w)² / Σ W w², the common shift max(v) cancels between numerator and denominator.
  const double log_num = 2.0 * log_sum_exp(logW + v);
  const double log_den = log_sum_exp(logW + 2.0 * v);
  if (log_num == kMinusInf) return 0.0;  // every weighted particle has zero likelihood
  return std::exp(log_num - log_den) / W.sum();
}

double conditional_ess(const Eigen::Ref<const Eigen::ArrayXd>& W,
                       const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta) {
  return static_cast<double>(W.size()) * relative_conditional_ess(W, loglik, delta);
}

double log_mean_weight_increment(const Eigen::Ref<const Eigen::ArrayXd>& W,
                                 const Eigen::Ref<const Eigen::ArrayXd>& loglik, double delta) {
  return log_sum_exp(W.log() + log_increment(loglik, delta)) - std::log(W.sum());
}

}  // namespace ssrfleet::smc
