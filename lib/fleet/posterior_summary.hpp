// Summaries of posterior draws, one column per quantity: mean, sd and the 2.5 / 97.5 % quantiles
// that the posterior-summary JSON reports (docs/outputs.md). Works on equally weighted draws (an
// MCMC chain) and on weighted ones (an SMC particle cloud) alike.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"

namespace ssrfleet::fleet {

struct ParameterSummary {
  double mean = 0.0;
  double sd = 0.0;
  double q025 = 0.0;
  double q975 = 0.0;
};

// The p-quantile (0 <= p <= 1) of weighted values (weights >= 0, not all 0; need not sum to 1).
// Each sorted value x_(i) sits at the midpoint of its weight's span of the cumulative weight,
// c_i = (W_(i-1) + W_i / 2) / W, and the quantile interpolates linearly between those points
// (below c_1 it is x_(1), above c_n it is x_(n)). With equal weights this is Hazen's
// definition, c_i = (i - 1/2) / n. Throws std::invalid_argument on bad weights or p.
double weighted_quantile(const Eigen::Ref<const Eigen::VectorXd>& values,
                         const Eigen::Ref<const Eigen::VectorXd>& weights, double p);

// Per column of `draws` (rows are draws): weighted mean, sd (with the reliability-weights
// correction W - sum w^2 / W, which is n - 1 for equal weights), q025 and q975. `weights`, if
// given, has one entry per row. Throws std::invalid_argument on fewer than 2 draws or bad weights.
std::vector<ParameterSummary> summarize_draws(const Eigen::Ref<const Eigen::MatrixXd>& draws,
                                              const Eigen::VectorXd* weights = nullptr);

// The same for a particle cloud laid out as PosteriorCloud has it (posterior_cloud.hpp): one
// column per draw, one row per quantity, and one weight per column.
std::vector<ParameterSummary> summarise_weighted(const Eigen::Ref<const Eigen::MatrixXd>& draws_by_column,
                                                 const Eigen::Ref<const Eigen::ArrayXd>& weights);

// The hyperparameter summary the posterior file reports (docs/outputs.md): one entry per row of
// cloud.theta (kHyperCount, fleet_model.hpp order), weighted by cloud.weights. Computed here so
// that io/posterior_json only formats it.
std::vector<ParameterSummary> summarise_cloud(const PosteriorCloud& cloud);
// The same for the model extension's parameters: one entry per row of cloud.psi (none for base).
std::vector<ParameterSummary> summarise_psi(const PosteriorCloud& cloud);

}  // namespace ssrfleet::fleet
