// One node's z-integral (truck_table.cpp's build): the Laplace-form coefficients of a (k, k_t) node
// and its z-likelihood in pieces, integrated over the lateral lines of its passes. Internal to the
// table build; not part of the model's interface.
#pragma once

#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Dense>

#include "model/fleet_model.hpp"
#include "model/truck_table.hpp"
#include "road/surface.hpp"
#include "util/gauss_legendre.hpp"

namespace ssrfleet::model::detail {

// What one node contributes: the Laplace-form coefficients, its z-moments at u_ref and their slopes.
struct NodeResult {
  double log_i_ref = -std::numeric_limits<double>::infinity();
  double c = 0.0, m = 0.0, b = 0.0;
  double z_mean = 0.0, z_var = 0.0, z_mean_slope = 0.0, z_var_slope = 0.0;
  // With a lateral reference: log of ∫ L(z) N(z | Z, σ_z²) dz / ∫ L(z) dz, exactly (the points).
  double lateral_exact = 0.0;
};

// log N(ẑ | Z, σ_z² + s²) as FleetMarginal evaluates it at u = u_ref (expanded in ε = s² / σ_z²).
inline double lateral_gaussian_form(double z_mean, double z_var, double mean, double sd) {
  const double var = sd * sd, eps = z_var / var, dz = z_mean - mean;
  return -0.5 * (fleet::kLog2Pi + std::log(var)) - 0.5 * eps - dz * dz / (2.0 * var) * (1.0 - eps + eps * eps);
}

// The z-integral of exp(-u SSR(z) / 2) over the lines [first, last] of one node's passes, by
// Gauss–Legendre on each segment. SSR is exactly quadratic on a segment: |e_a - w d|².
// The node's z-likelihood is returned in pieces of consecutive segments, each with a z-posterior
// sd of at most max_piece_sd (one piece when the whole node's is below it). FleetMarginal applies
// the lateral prior to each piece by moment matching, whose error falls like (piece sd / σ_z)⁴:
// a broad, many-peaked z-likelihood (road AS2) matched as one Gaussian was off by 0.1-0.2 nats
// per truck; cut into pieces it is exact to the budget (truck_table.hpp, "Pieces").
std::vector<NodeResult> integrate_node(const Eigen::Ref<const Eigen::ArrayXXd>& ifs_by_line, Eigen::Index first_line,
                                       const road::Surface& surface, const Eigen::Ref<const Eigen::VectorXd>& y,
                                       double u_ref, const util::QuadratureRule& rule, double max_piece_sd,
                                       const std::optional<TruckTableOptions::LateralReference>& lateral);

}  // namespace ssrfleet::model::detail
