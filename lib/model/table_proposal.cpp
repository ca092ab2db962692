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

TableProposal::TableProposal(const TableView& table, const FleetMarginal& marginal, const fleet::HyperVector& theta)
    : TableProposal(table, marginal, marginal.prepare(theta)) {}

TableProposal::TableProposal(const TableView& table, const FleetMarginal& marginal, const ThetaTerms& terms) {
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
  // Entries whose share is below e^-kPruneNats of the largest are left out (and the rest
  // renormalised): the mixture drawn from and the density returned stay one and the same, so an
  // importance weight or an MH ratio built on them stays exact, and a table of thousands of nodes
  // of which a few dozen carry weight at this θ costs only those.
  constexpr float kPruneNats = 30.0f;
  double total = 0.0;
  for (std::size_t g = 0; g < n; ++g) {
    if (!(e[g] >= top - kPruneNats)) continue;
    const double w = std::exp(static_cast<double>(e[g] - top));
    total += w;
    cumulative_.push_back(total);
    log_pi_.push_back(static_cast<double>(e[g] - top));
    k_npm_.push_back(lattice.k_at(table.k_index[g]));
    kt_npm_.push_back(lattice.kt_at(table.kt_index[g]));
    // The entry's z-likelihood N(ẑ_g(u), s²_g(u)) (its moments at u, as FleetMarginal takes them)
    // times the lateral prior N(Z, σ_z²).
    const FleetMarginal::EntryMoments z = FleetMarginal::entry_moments(table, g, terms.u);
    const double s2 = std::max(0.0, z.z_var_m2);
    const double post_var = s2 > 0.0 ? 1.0 / (1.0 / s2 + 1.0 / prior_var) : 0.0;
    const double post_mean = s2 > 0.0 ? post_var * (z.z_mean_m / s2 + terms.lateral_mean_m / prior_var) : z.z_mean_m;
    z_mean_m_.push_back(post_mean);
    z_sd_m_.push_back(std::max(kMinLateralSdM, std::sqrt(post_var)));
  }
  const double log_total = std::log(total);
  for (auto& c : cumulative_) c /= total;
  cumulative_.back() = 1.0;
  for (auto& l : log_pi_) l -= log_total;
  // log π_g + the three Gaussians' normalising constants, once: log_density is called per draw.
  constexpr double kLogTwoPi = 1.8378770664093453;
  log_constant_.resize(log_pi_.size());
  for (std::size_t g = 0; g < log_pi_.size(); ++g) {
    log_constant_[g] = log_pi_[g] - std::log(k_spread_npm_) - std::log(kt_spread_npm_) - std::log(z_sd_m_[g]) - 1.5 * kLogTwoPi;
  }
}

double TableProposal::log_density(const TruckLatent& x) const {
  // log Σ_g exp(t_g) in one pass, rescaling when a larger term turns up.
  double top = -std::numeric_limits<double>::infinity(), sum = 0.0;
  for (std::size_t g = 0; g < k_npm_.size(); ++g) {
    const double dk = (x.stiffness_npm - k_npm_[g]) / k_spread_npm_;
    const double dkt = (x.tyre_stiffness_npm - kt_npm_[g]) / kt_spread_npm_;
    const double dz = (x.lateral_m - z_mean_m_[g]) / z_sd_m_[g];
    const double t = log_constant_[g] - 0.5 * (dk * dk + dkt * dkt + dz * dz);
    // A term more than 50 nats below the largest is below the sum's rounding (e^-50 < 1e-21), and
    // glibc's exp takes a slow path on results that deep: skip it.
    constexpr double kNegligible = -50.0;
    if (t > top) {
      sum = (top - t > kNegligible ? sum * std::exp(top - t) : 0.0) + 1.0;
      top = t;
    } else if (t - top > kNegligible) {
      sum += std::exp(t - top);
    }
  }
  if (!(top > -std::numeric_limits<double>::infinity())) return top;
  return top + std::log(sum);
}

}  // namespace ssrfleet::model
