#include "fleet/equal_weight_draws.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "model/fleet_model.hpp"

namespace ssrfleet::fleet {

std::vector<Eigen::Index> systematic_half_offset(const Eigen::Ref<const Eigen::ArrayXd>& weights,
                                                 Eigen::Index count) {
  double total = 0.0;
  for (Eigen::Index j = 0; j < weights.size(); ++j) {
    if (!std::isfinite(weights[j]) || weights[j] < 0.0) {
      throw std::invalid_argument("systematic_half_offset(): weight " + std::to_string(j) +
                                  " is not a finite number >= 0");
    }
    total += weights[j];
  }
  if (!(total > 0.0) || !std::isfinite(total))
    throw std::invalid_argument("systematic_half_offset(): weights sum to 0");
  if (count < 0) throw std::invalid_argument("systematic_half_offset(): negative count");
  std::vector<Eigen::Index> picked;
  picked.reserve(static_cast<std::size_t>(count));
  // Compare in units of draws: (i + 1/2) against D W_j / total, so whole counts stay exact.
  const double scale = static_cast<double>(count) / total;
  double cumulative = 0.0;
  Eigen::Index j = 0;
  for (Eigen::Index i = 0; i < count; ++i) {
    const double point = static_cast<double>(i) + 0.5;
    while (j < weights.size() - 1 && cumulative + weights[j] * scale <= point) {
      cumulative += weights[j] * scale;
      ++j;
    }
    picked.push_back(j);
  }
  return picked;
}

EqualWeightDraws equal_weight_draws(const PosteriorCloud& cloud) {
  const Eigen::Index columns = cloud.theta.cols();
  if (cloud.theta.rows() != kHyperCount)
    throw std::invalid_argument("equal_weight_draws(): theta needs 7 rows");
  if (cloud.weights.size() != columns)
    throw std::invalid_argument("equal_weight_draws(): weights and theta differ in length");
  if (cloud.psi.rows() > 0 && cloud.psi.cols() != columns) {
    throw std::invalid_argument("equal_weight_draws(): psi and theta differ in length");
  }
  // A cloud holds `chains` runs (MCMC chains, or SMC runs of fit --runs); an SMC run's pooled
  // final sweeps are copies of one run, not chains.
  const int chains = cloud.chains;
  if (chains < 1 || columns == 0 || columns % chains != 0) {
    throw std::invalid_argument("equal_weight_draws(): " + std::to_string(columns) +
                                " draws do not split into " + std::to_string(chains) + " chains");
  }
  EqualWeightDraws out;
  out.chains = chains;
  out.draws = columns / chains;
  out.theta.resize(kHyperCount, columns);
  out.psi.resize(cloud.psi.rows(), columns);
  out.source.reserve(static_cast<std::size_t>(columns));
  for (int c = 0; c < chains; ++c) {
    const Eigen::Index begin = c * out.draws;
    const auto picked = systematic_half_offset(cloud.weights.segment(begin, out.draws), out.draws);
    for (Eigen::Index d = 0; d < out.draws; ++d) {
      const Eigen::Index from = begin + picked[static_cast<std::size_t>(d)];
      out.theta.col(begin + d) = cloud.theta.col(from);
      if (cloud.psi.rows() > 0) out.psi.col(begin + d) = cloud.psi.col(from);
      out.source.push_back(from);
    }
  }
  return out;
}

}  // namespace ssrfleet::fleet
