#include "fleet/posterior_summary.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace ssrfleet::fleet {

namespace {
void check_weights(const char* function, const Eigen::Ref<const Eigen::VectorXd>& weights, Eigen::Index n) {
  if (weights.size() != n) {
    throw std::invalid_argument(std::string(function) + ": " + std::to_string(weights.size()) +
                                " weights for " + std::to_string(n) + " values");
  }
  if (!weights.allFinite() || (weights.array() < 0.0).any() || !(weights.sum() > 0.0)) {
    throw std::invalid_argument(std::string(function) +
                                ": weights must be finite, non-negative and not all zero");
  }
}
}  // namespace

double weighted_quantile(const Eigen::Ref<const Eigen::VectorXd>& values,
                         const Eigen::Ref<const Eigen::VectorXd>& weights, double p) {
  constexpr const char* fn = "weighted_quantile";
  const Eigen::Index n = values.size();
  if (n < 1) throw std::invalid_argument(std::string(fn) + ": no values");
  check_weights(fn, weights, n);
  if (!(p >= 0.0 && p <= 1.0)) throw std::invalid_argument(std::string(fn) + ": p must be in [0, 1]");
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return values[a] < values[b]; });
  const double total = weights.sum();
  double cumulative = 0.0, prev_c = 0.0, prev_x = values[order.front()];
  bool have_prev = false;
  for (const Eigen::Index i : order) {
    const double w = weights[i];
    if (w <= 0.0) continue;  // a zero-weight value is not part of the distribution
    const double c = (cumulative + 0.5 * w) / total;
    cumulative += w;
    if (p <= c) {
      if (!have_prev) return values[i];
      const double t = (p - prev_c) / (c - prev_c);
      return prev_x + t * (values[i] - prev_x);
    }
    prev_c = c;
    prev_x = values[i];
    have_prev = true;
  }
  return prev_x;
}

std::vector<ParameterSummary> summarize_draws(const Eigen::Ref<const Eigen::MatrixXd>& draws,
                                              const Eigen::VectorXd* weights) {
  constexpr const char* fn = "summarize_draws";
  const Eigen::Index n = draws.rows();
  if (n < 2)
    throw std::invalid_argument(std::string(fn) + ": need at least 2 draws, got " + std::to_string(n));
  const Eigen::VectorXd w = weights ? *weights : Eigen::VectorXd::Ones(n);
  check_weights(fn, w, n);
  const double total = w.sum();
  const double effective_denominator = total - w.squaredNorm() / total;
  std::vector<ParameterSummary> out(static_cast<std::size_t>(draws.cols()));
  for (Eigen::Index j = 0; j < draws.cols(); ++j) {
    ParameterSummary& s = out[static_cast<std::size_t>(j)];
    const Eigen::VectorXd column = draws.col(j);
    s.mean = w.dot(column) / total;
    const double ss = w.dot((column.array() - s.mean).square().matrix());
    s.sd = effective_denominator > 0.0 ? std::sqrt(ss / effective_denominator) : 0.0;
    s.q025 = weighted_quantile(column, w, 0.025);
    s.q975 = weighted_quantile(column, w, 0.975);
  }
  return out;
}

std::vector<ParameterSummary> summarise_weighted(const Eigen::Ref<const Eigen::MatrixXd>& draws_by_column,
                                                 const Eigen::Ref<const Eigen::ArrayXd>& weights) {
  const Eigen::MatrixXd draws = draws_by_column.transpose();
  const Eigen::VectorXd w = weights.matrix();
  return summarize_draws(draws, &w);
}

std::vector<ParameterSummary> summarise_cloud(const PosteriorCloud& cloud) {
  return summarise_weighted(cloud.theta, cloud.weights);
}

std::vector<ParameterSummary> summarise_psi(const PosteriorCloud& cloud) {
  if (cloud.psi.rows() == 0) return {};
  return summarise_weighted(cloud.psi, cloud.weights);
}

}  // namespace ssrfleet::fleet
