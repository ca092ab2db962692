// A proposal for one truck's latents x = (k, k_t, z) given the fleet's θ, built from the truck's
// table (truck_table.hpp): what the marginal core needs when something asks for latents after all
// (docs/inference.md: the marginal core keeps no latents and draws them from p(x_i | y_i, θ) only
// when something needs them, as the posterior predictive checks of diagnose do).
//
// The node sum ℓ_i(θ) = C(θ) Σ_g exp(e_g) (FleetMarginal::entry_exponents) is the rectangle rule
// for ∫ p(y | x) p(x | θ) dx, so entry g carries the share π_g ∝ exp(e_g) of the truck's latent
// posterior: the mass of its (k, k_t) cell, with z distributed as the entry's z-likelihood (its
// moments ẑ_g, s²_g at σ_IF) times the lateral prior N(Z, σ_z²). The proposal is the mixture
//   q(x) = Σ_g π_g N(k; k_g, h_k²) N(k_t; kt_g, h_kt²) N(z; m_g, v_g),
// h half the lattice spacing (a smooth spread over each cell, wider than the target where it
// matters for an independence sampler), (m_g, v_g) the Gaussian product of the entry's
// z-likelihood and the prior. It is only a proposal: the caller corrects it to p(x | y, θ) exactly
// by Metropolis–Hastings with the integrator (discrepancy/marginal_draws.hpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "model/fleet_marginal.hpp"
#include "model/truncated_samplers.hpp"

namespace ssrfleet::model {

struct TruckLatent {
  double stiffness_npm = 0.0;
  double tyre_stiffness_npm = 0.0;
  double lateral_m = 0.0;
};

class TableProposal {
 public:
  // `marginal` holds the lattice the table was built on. UsageError if θ is outside the support
  // or the table carries no weight at θ.
  TableProposal(const TableView& table, const FleetMarginal& marginal, const fleet::HyperVector& theta);
  // The same from θ's terms as prepared for the fleet's stiffness distribution (an extension's
  // mixture weighting the nodes: FleetMarginal::prepare).
  TableProposal(const TableView& table, const FleetMarginal& marginal, const ThetaTerms& terms);

  template <class Engine>
  TruckLatent draw(Engine& engine) const;
  double log_density(const TruckLatent& x) const;

  std::size_t entries() const { return k_npm_.size(); }

 private:
  std::vector<double> cumulative_;  // Σ_{h<=g} π_h, the last one 1
  std::vector<double> log_pi_;
  std::vector<double> k_npm_, kt_npm_, z_mean_m_, z_sd_m_;
  std::vector<double> log_constant_;  // log π_g and the Gaussians' normalising constants
  double k_spread_npm_ = 0.0, kt_spread_npm_ = 0.0;
};

template <class Engine>
TruckLatent TableProposal::draw(Engine& engine) const {
  const double u = fleet::uniform_open01(engine);
  // The first entry whose cumulative share reaches u (the last one is exactly 1).
  const auto g = static_cast<std::size_t>(std::lower_bound(cumulative_.begin(), cumulative_.end(), u) - cumulative_.begin());
  constexpr double kInf = std::numeric_limits<double>::infinity();
  auto normal = [&engine] { return fleet::truncated_normal_quantile(fleet::uniform_open01(engine), 0.0, 1.0, -kInf, kInf); };
  TruckLatent x;
  x.stiffness_npm = k_npm_[g] + k_spread_npm_ * normal();
  x.tyre_stiffness_npm = kt_npm_[g] + kt_spread_npm_ * normal();
  x.lateral_m = z_mean_m_[g] + z_sd_m_[g] * normal();
  return x;
}

}  // namespace ssrfleet::model
