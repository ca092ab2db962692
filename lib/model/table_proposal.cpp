#include "model/table_proposal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "model/fleet_model.hpp"
#include "util/errors.hpp"

namespace ssrfleet::model {

namespace {
// A z-sd below this (an entry whose z-likelihood is a spike) is widened to it: the proposal must
// not be narrower than the target, and a tenth of a millimetre is far below any road's line
// spacing.
constexpr double kMinLateralSdM = 1e-4;
}  // namespace

TableProposal::TableProposal(const TableView& table, const FleetMarginal& marginal, const fleet::HyperVector& theta) {
  const ThetaTerms terms = marginal.prepare(theta);
  if (!terms.inside) throw UsageError("TableProposal: theta is outside the fleet model's support");
  const std::size_t n = table.nodes;
  std::vector<float> e(n);
  marginal.entry_exponents(table, terms, e.data());
  const float top = n > 0 ? *std::max_element(e.begin(), e.end()) : -std::numeric_limits<float>::infinity();
  if (!(top > -std::numeric_limits<float>::infinity())) {
    throw UsageError("TableProposal: the truck's table carries no weight at this theta");
  }
  const Lattice& lattice = marginal.lattice();
  k_spread_npm_ = 0.5 * lattice.dk_npm;
  kt_spread_npm_ = 0.5 * lattice.dkt_npm;
  const double prior_var = terms.lateral_var_m2;
  double total = 0.0;
  for (std::size_t g = 0; g < n; ++g) {
    const double w = std::exp(static_cast<double>(e[g] - top));
    if (!(w > 0.0)) continue;  // underflowed: no share to draw
    total += w;
    cumulative_.push_back(total);
    log_pi_.push_back(static_cast<double>(e[g] - top));
    k_npm_.push_back(lattice.k_at(table.k_index[g]));
    kt_npm_.push_back(lattice.kt_at(table.kt_index[g]));
    // The entry's z-likelihood N(ẑ_g, s²_g) (s² scaled from u_ref to u, as FleetMarginal does)
    // times the lateral prior N(Z, σ_z²).
    const double s2 = std::max(0.0, static_cast<double>(table.z_var_m2[g])) * table.u_ref / terms.u;
    const double post_var = s2 > 0.0 ? 1.0 / (1.0 / s2 + 1.0 / prior_var) : 0.0;
    const double post_mean =
        s2 > 0.0 ? post_var * (static_cast<double>(table.z_mean_m[g]) / s2 + terms.lateral_mean_m / prior_var)
                 : static_cast<double>(table.z_mean_m[g]);
    z_mean_m_.push_back(post_mean);
    z_sd_m_.push_back(std::max(kMinLateralSdM, std::sqrt(post_var)));
  }
  const double log_total = std::log(total);
  for (auto& c : cumulative_) c /= total;
  cumulative_.back() = 1.0;
  for (auto& l : log_pi_) l -= log_total;
}

double TableProposal::log_density(const TruckLatent& x) const {
  double top = -std::numeric_limits<double>::infinity();
  std::vector<double> terms(k_npm_.size());
  for (std::size_t g = 0; g < k_npm_.size(); ++g) {
    terms[g] = log_pi_[g] + fleet::log_normal_density(x.stiffness_npm, k_npm_[g], k_spread_npm_) +
               fleet::log_normal_density(x.tyre_stiffness_npm, kt_npm_[g], kt_spread_npm_) +
               fleet::log_normal_density(x.lateral_m, z_mean_m_[g], z_sd_m_[g]);
    top = std::max(top, terms[g]);
  }
  if (!(top > -std::numeric_limits<double>::infinity())) return top;
  double sum = 0.0;
  for (double t : terms) sum += std::exp(t - top);
  return top + std::log(sum);
}

}  // namespace ssrfleet::model
