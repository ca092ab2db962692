#include "util/convergence.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include <boost/math/distributions/normal.hpp>
#include <boost/math/special_functions/beta.hpp>

#include "util/effective_sample_size.hpp"
#include "util/quantile.hpp"

namespace ssrfleet::util {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// NaN-worthy input: a non-finite draw or all draws equal.
bool degenerate(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  return draws.size() == 0 || !draws.allFinite() || draws.maxCoeff() == draws.minCoeff();
}

std::vector<double> all_draws(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  std::vector<double> values(static_cast<std::size_t>(draws.size()));
  Eigen::Index i = 0;
  for (Eigen::Index c = 0; c < draws.cols(); ++c)
    for (Eigen::Index r = 0; r < draws.rows(); ++r) values[static_cast<std::size_t>(i++)] = draws(r, c);
  return values;
}

std::vector<double> sorted_draws(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  std::vector<double> values = all_draws(draws);
  std::sort(values.begin(), values.end());
  return values;
}

// Φ(-1) and Φ(1): the normal probabilities below one sd under and one sd over the mean.
const double kPhiMinusOne = 0.5 * std::erfc(1.0 / std::sqrt(2.0));
const double kPhiPlusOne = 1.0 - kPhiMinusOne;

// The MCSE of the p-quantile from the ESS of its indicator and the draws sorted.
double quantile_mcse(const std::vector<double>& sorted, double ess, double p) {
  if (std::isnan(ess)) return kNaN;
  const double a = ess * p + 1.0, b = ess * (1.0 - p) + 1.0;
  const double lower_probability = boost::math::ibeta_inv(a, b, kPhiMinusOne);
  const double upper_probability = boost::math::ibeta_inv(a, b, kPhiPlusOne);
  const auto s = static_cast<double>(sorted.size());
  // 1-based order statistics, clamped to [1, S].
  const double lower_rank = std::max(std::floor(lower_probability * s), 1.0);
  const double upper_rank = std::min(std::ceil(upper_probability * s), s);
  const double lower = sorted[static_cast<std::size_t>(lower_rank) - 1];
  const double upper = sorted[static_cast<std::size_t>(upper_rank) - 1];
  return 0.5 * (upper - lower);
}

double sample_sd(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  const auto s = static_cast<double>(draws.size());
  if (!(s > 1.0)) return kNaN;
  return std::sqrt((draws.array() - draws.mean()).square().sum() / (s - 1.0));
}

}  // namespace

Eigen::MatrixXd split_chains(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  const Eigen::Index n = draws.rows(), m = draws.cols();
  if (n < 2) return draws;
  const Eigen::Index half = n / 2;
  Eigen::MatrixXd split(half, 2 * m);
  for (Eigen::Index c = 0; c < m; ++c) {
    split.col(2 * c) = draws.col(c).head(half);
    split.col(2 * c + 1) = draws.col(c).tail(half);  // skips the middle draw of an odd n
  }
  return split;
}

Eigen::MatrixXd rank_normalise(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  const Eigen::Index s = draws.size();
  Eigen::MatrixXd z(draws.rows(), draws.cols());
  if (s == 0) return z;
  // (value, position in z) pairs sorted by value: ties end up next to each other.
  std::vector<std::pair<double, Eigen::Index>> order(static_cast<std::size_t>(s));
  for (Eigen::Index c = 0, i = 0; c < draws.cols(); ++c)
    for (Eigen::Index r = 0; r < draws.rows(); ++r, ++i)
      order[static_cast<std::size_t>(i)] = {draws(r, c), i};
  std::sort(order.begin(), order.end());
  const boost::math::normal standard;
  const double denominator = static_cast<double>(s) + 0.25;
  for (std::size_t first = 0; first < order.size();) {
    std::size_t last = first + 1;  // [first, last) share one value
    while (last < order.size() && order[last].first == order[first].first) ++last;
    // 1-based ranks first+1 .. last, averaged.
    const double rank = 0.5 * static_cast<double>(first + 1 + last);
    const double score = boost::math::quantile(standard, (rank - 0.375) / denominator);
    for (std::size_t i = first; i < last; ++i) z.data()[order[i].second] = score;
    first = last;
  }
  return z;
}

double basic_rhat(const Eigen::Ref<const Eigen::MatrixXd>& chains) {
  const Eigen::Index n = chains.rows(), m = chains.cols();
  if (n < 2 || m < 2 || degenerate(chains)) return kNaN;
  const auto n_draws = static_cast<double>(n);
  const Eigen::VectorXd means = chains.colwise().mean().transpose();
  double within = 0.0;
  for (Eigen::Index c = 0; c < m; ++c)
    within += (chains.col(c).array() - means[c]).square().sum() / (n_draws - 1.0);
  within /= static_cast<double>(m);
  const double between_over_n = (means.array() - means.mean()).square().sum() / static_cast<double>(m - 1);
  if (!(within > 0.0)) return kNaN;
  return std::sqrt(((n_draws - 1.0) / n_draws * within + between_over_n) / within);
}

double rhat_bulk(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  if (degenerate(draws)) return kNaN;
  return basic_rhat(rank_normalise(split_chains(draws)));
}

// The public functions take the draws alone; these take what the summary computes once.
namespace {

double rhat_tail_about(const Eigen::Ref<const Eigen::MatrixXd>& draws, double median) {
  const Eigen::MatrixXd folded = (draws.array() - median).abs().matrix();
  if (degenerate(folded)) return kNaN;
  return basic_rhat(rank_normalise(split_chains(folded)));
}

double rhat_unsplit_about(const Eigen::Ref<const Eigen::MatrixXd>& draws, double median) {
  if (degenerate(draws)) return kNaN;
  const Eigen::MatrixXd folded = (draws.array() - median).abs().matrix();
  if (degenerate(folded)) return kNaN;
  const double bulk = basic_rhat(rank_normalise(draws)), tail = basic_rhat(rank_normalise(folded));
  if (std::isnan(bulk) || std::isnan(tail)) return kNaN;
  return std::max(bulk, tail);
}

// ESS of the indicator chains I(θ <= threshold), split.
double ess_at_or_below(const Eigen::Ref<const Eigen::MatrixXd>& draws, double threshold) {
  const Eigen::MatrixXd below = (draws.array() <= threshold).cast<double>().matrix();
  return multi_chain_effective_sample_size(split_chains(below));
}

void check_probability(const char* function, double p) {
  if (!(p > 0.0 && p < 1.0))
    throw std::invalid_argument(std::string(function) + ": p is " + std::to_string(p) +
                                ", but must be in (0, 1)");
}

}  // namespace

double rhat_tail(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  if (degenerate(draws)) return kNaN;
  return rhat_tail_about(draws, sorted_quantile_type7(sorted_draws(draws), 0.5));
}

double rhat(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  const double bulk = rhat_bulk(draws), tail = rhat_tail(draws);
  if (std::isnan(bulk) || std::isnan(tail)) return kNaN;
  return std::max(bulk, tail);
}

double rhat_unsplit(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  if (degenerate(draws)) return kNaN;
  return rhat_unsplit_about(draws, sorted_quantile_type7(sorted_draws(draws), 0.5));
}

double ess_bulk(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  if (degenerate(draws)) return kNaN;
  return multi_chain_effective_sample_size(rank_normalise(split_chains(draws)));
}

double ess_quantile(const Eigen::Ref<const Eigen::MatrixXd>& draws, double p) {
  check_probability("ess_quantile", p);
  if (degenerate(draws)) return kNaN;
  return ess_at_or_below(draws, sorted_quantile_type7(sorted_draws(draws), p));
}

double ess_tail(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  const double lower = ess_quantile(draws, 0.05), upper = ess_quantile(draws, 0.95);
  if (std::isnan(lower) || std::isnan(upper)) return kNaN;
  return std::min(lower, upper);
}

double ess_mean(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  if (degenerate(draws)) return kNaN;
  return multi_chain_effective_sample_size(split_chains(draws));
}

double mcse_mean(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  return sample_sd(draws) / std::sqrt(ess_mean(draws));  // NaN propagates
}

double mcse_quantile(const Eigen::Ref<const Eigen::MatrixXd>& draws, double p) {
  check_probability("mcse_quantile", p);
  if (degenerate(draws)) return kNaN;
  const std::vector<double> sorted = sorted_draws(draws);
  return quantile_mcse(sorted, ess_at_or_below(draws, sorted_quantile_type7(sorted, p)), p);
}

ConvergenceSummary summarise_convergence(const Eigen::Ref<const Eigen::MatrixXd>& draws) {
  if (draws.rows() == 0 || draws.cols() == 0)
    throw std::invalid_argument("summarise_convergence: " + std::to_string(draws.rows()) + " draws of " +
                                std::to_string(draws.cols()) + " chains, but must have at least one of each");
  ConvergenceSummary out;
  out.chains = draws.cols();
  out.draws_per_chain = draws.rows();
  out.mean = draws.mean();
  out.sd = sample_sd(draws);
  const std::vector<double> values = sorted_draws(draws);
  out.q05 = sorted_quantile_type7(values, 0.05);
  out.q50 = sorted_quantile_type7(values, 0.5);
  out.q95 = sorted_quantile_type7(values, 0.95);
  const bool undefined = degenerate(draws);
  out.rhat_bulk = rhat_bulk(draws);
  out.rhat_tail = undefined ? kNaN : rhat_tail_about(draws, out.q50);
  out.rhat =
      std::isnan(out.rhat_bulk) || std::isnan(out.rhat_tail) ? kNaN : std::max(out.rhat_bulk, out.rhat_tail);
  out.rhat_unsplit = undefined ? kNaN : rhat_unsplit_about(draws, out.q50);
  out.ess_bulk = ess_bulk(draws);
  out.ess_q05 = undefined ? kNaN : ess_at_or_below(draws, out.q05);
  out.ess_q95 = undefined ? kNaN : ess_at_or_below(draws, out.q95);
  out.ess_tail =
      std::isnan(out.ess_q05) || std::isnan(out.ess_q95) ? kNaN : std::min(out.ess_q05, out.ess_q95);
  out.ess_mean = ess_mean(draws);
  out.mcse_mean = out.sd / std::sqrt(out.ess_mean);
  out.mcse_q05 = quantile_mcse(values, out.ess_q05, 0.05);
  out.mcse_q95 = quantile_mcse(values, out.ess_q95, 0.95);
  return out;
}

std::vector<ConvergenceSummary> summarise_parameters(const std::vector<Eigen::MatrixXd>& chains,
                                                     const ParallelRange& parallel) {
  if (chains.empty()) throw std::invalid_argument("summarise_parameters: no chains");
  const Eigen::Index n = chains.front().rows(), k = chains.front().cols();
  for (std::size_t c = 1; c < chains.size(); ++c)
    if (chains[c].rows() != n || chains[c].cols() != k)
      throw std::invalid_argument("summarise_parameters: chain " + std::to_string(c) + " is " +
                                  std::to_string(chains[c].rows()) + " × " +
                                  std::to_string(chains[c].cols()) + ", but chain 0 is " + std::to_string(n) +
                                  " × " + std::to_string(k));
  std::vector<ConvergenceSummary> out(static_cast<std::size_t>(k));
  // Each parameter is summarised on its own, so the chunking cannot change a bit.
  parallel(k, [&](Eigen::Index begin, Eigen::Index end) {
    Eigen::MatrixXd draws(n, static_cast<Eigen::Index>(chains.size()));
    for (Eigen::Index j = begin; j < end; ++j) {
      for (std::size_t c = 0; c < chains.size(); ++c)
        draws.col(static_cast<Eigen::Index>(c)) = chains[c].col(j);
      out[static_cast<std::size_t>(j)] = summarise_convergence(draws);
    }
  });
  return out;
}

}  // namespace ssrfleet::util
