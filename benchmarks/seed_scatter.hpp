// The Monte Carlo error of an SMC posterior, measured directly: the same data fitted with R
// seeds. The scatter of the R posterior means, set against the posterior sd, says how many
// independent draws the SMC's estimate is worth, its "equivalent ESS" = (posterior sd / scatter)²,
// which is what an MCMC chain's ESS means too. So "SMC vs MCMC to the same accuracy" compares
// like with like. With R runs the scatter's square is known only to a χ²(R − 1) factor, so the
// equivalent ESS comes with a 90 % interval.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <boost/math/distributions/chi_squared.hpp>

#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"

namespace ssrfleet::bench {

using RunSummary = std::vector<fleet::ParameterSummary>;  // kHyperCount entries, fleet_model.hpp order

struct SeedScatter {
  int runs = 0;
  std::array<double, fleet::kHyperCount> scatter{};         // sd over runs of the posterior mean
  std::array<double, fleet::kHyperCount> posterior_sd{};    // mean over runs of the posterior sd
  std::array<double, fleet::kHyperCount> equivalent_ess{};  // (posterior_sd / scatter)²
  int worst = 0;                                            // hyperparameter with the smallest
  double min_ess = 0.0;
  double min_ess_lo90 = 0.0, min_ess_hi90 = 0.0;            // its 90 % interval
};

inline SeedScatter seed_scatter(const std::vector<RunSummary>& runs) {
  SeedScatter s;
  s.runs = static_cast<int>(runs.size());
  if (runs.size() < 2) return s;
  const double n = static_cast<double>(runs.size());
  s.min_ess = std::numeric_limits<double>::infinity();
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto J = static_cast<std::size_t>(j);
    double mean = 0.0, sd = 0.0;
    for (const auto& r : runs) mean += r[J].mean / n, sd += r[J].sd / n;
    double ss = 0.0;
    for (const auto& r : runs) ss += (r[J].mean - mean) * (r[J].mean - mean);
    s.scatter[J] = std::sqrt(ss / (n - 1.0));
    s.posterior_sd[J] = sd;
    s.equivalent_ess[J] = s.scatter[J] > 0.0 ? (sd / s.scatter[J]) * (sd / s.scatter[J])
                                             : std::numeric_limits<double>::infinity();
    if (s.equivalent_ess[J] < s.min_ess) s.min_ess = s.equivalent_ess[J], s.worst = j;
  }
  // scatter² ~ σ² χ²(R−1)/(R−1), so the true ESS is the estimate times χ²(R−1)/(R−1).
  const boost::math::chi_squared chi2(n - 1.0);
  s.min_ess_lo90 = s.min_ess * boost::math::quantile(chi2, 0.05) / (n - 1.0);
  s.min_ess_hi90 = s.min_ess * boost::math::quantile(chi2, 0.95) / (n - 1.0);
  return s;
}

}  // namespace ssrfleet::bench
