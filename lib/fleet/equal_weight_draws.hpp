// Equal-weight draws of a posterior cloud, chain by chain, for tools that expect plain MCMC-style
// draws (ArviZ, pandas; io/draws_csv.hpp, io/draws_netcdf.hpp).
//
// A chain is one independent run: each of a posterior's `chains` blocks of theta (equal counts,
// one after the other): an MCMC chain, or an SMC run (fit --runs; one run's pooled final sweeps
// are copies of that run, not chains). Within a chain of weights w_1..w_P (renormalised to sum to 1)
// the D draws are picked by systematic resampling with the offset fixed at one half:
//   draw i (i = 0..D-1) is the particle j with W_{j-1} <= (i + 1/2) / D < W_j,  W_j = w_1 + ... + w_j.
// No random number is drawn, so a posterior file always gives the same draws. A particle of weight
// n_j / D (n_j whole) is drawn exactly n_j times: the points (i + 1/2) / D sit half a spacing away
// from every such W_j, far beyond rounding. Equal weights (MCMC) give every draw once, in the
// chain's order, so the draws keep their autocorrelation for R-hat and ESS. The draws of a chain
// come in particle order; D is the chain's particle count.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "fleet/posterior_cloud.hpp"

namespace ssrfleet::fleet {

struct EqualWeightDraws {
  int chains = 0;
  Eigen::Index draws = 0;  // per chain
  // Column c * draws + d is chain c's draw d: kHyperCount rows (fleet_model.hpp order), and the
  // cloud's psi rows (psi_names order; 0 rows for the base model).
  Eigen::MatrixXd theta;
  Eigen::MatrixXd psi;
  std::vector<Eigen::Index> source;  // the cloud column each draw copies
};

// The indices of `count` systematic draws (offset 1/2) from `weights` (>= 0, finite, positive sum;
// std::invalid_argument otherwise), in increasing order.
std::vector<Eigen::Index> systematic_half_offset(const Eigen::Ref<const Eigen::ArrayXd>& weights,
                                                 Eigen::Index count);

// The cloud's equal-weight draws as above. std::invalid_argument for a cloud whose columns do not
// split into its chains, or whose weights or psi do not match theta's columns.
EqualWeightDraws equal_weight_draws(const PosteriorCloud& cloud);

}  // namespace ssrfleet::fleet
