// The marginal core's ψ window: how MarginalTarget carries a one-parameter effect that acts inside
// the dynamics (a vehicle constant, the speed), whose ψ changes every pass the tables hold.
//
// Every absorbed truck keeps Q tables, one per node ψ_q of one window [lo, hi] shared by all trucks
// (model/psi_grid.hpp: Chebyshev points of the second kind), and
//   ℓ_i(θ, ψ) = Σ_q L_q(ψ) ℓ_i(θ, ψ_q),
// so Σ_i ℓ_i(θ, ψ) = Σ_q L_q(ψ) S_q(θ) with S_q(θ) = Σ_i ℓ_i(θ, ψ_q): each node's sum is the base
// model's sum over its own store (exact, in util::ExactSum, so the bits do not depend on threads or
// ranks), and the Lagrange weights are computed once per particle per evaluation and combined
// after the exact sums are complete.
//
// The window follows the ψ posterior (model::PsiWindowRule): while it is as broad as the prior box
// the window is the box, with box_nodes evenly spaced nodes and the piecewise-linear interpolant
// (one truck's ℓ_i(ψ) across the whole box is far from a polynomial); then the posterior mean ± 6
// posterior sd, clipped to the box, with rule.nodes Chebyshev nodes (the prototype's record measured
// Q = 5 on ±6 sd at ≤ 0.038 nats summed over the trucks from n = 20 to 10,000). A ψ inside the box but
// outside the window has density 0 (-inf): the interpolant extrapolates badly there, and the window holds ±6
// sd of the posterior (a mass of 2e-9 outside for a normal) and is moved, with every table rebuilt, as soon
// as mean ± 4 sd leaves it (check_psi_window's kMoved), so the truncation never binds on more than
// the far tail.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "model/model_extension.hpp"
#include "model/psi_grid.hpp"
#include "util/exact_sum.hpp"

namespace ssrfleet::fleet {

// Whether the marginal core carries an extension through a ψ window: one continuous parameter that
// edits the pass (a vehicle constant, the speed) or the output (a gain on a given sensor,
// sensor_gain:sensor=N); no added profile (a pass per node more, not measured), no discrete choice
// (sensor_gain with its sensor free has two parameters), no jump.
bool carried_by_psi_window(const ModelExtension* extension);
// Whether a carried extension fits on the marginal core by default (choose_core, online_fit.hpp).
// speed_bias does not: a scaled speed moves each pass's timing along the whole array and its tables
// keep 600-690 entries against about 100 for tyre_damping; on a 40-truck log its marginal refit
// inside diagnose ran for minutes where the latent one takes seconds, and a 12-truck fit with a
// factor of 1.1 and 128 particles put the truth below its 95 % interval. It still fits on the
// marginal core when asked (--core marginal), and agrees there with the batch MCMC at 50 trucks.
bool psi_window_by_default(const ModelExtension* extension);

// The largest Q a window may have (the particles' weights are kept on the stack).
constexpr int kMaxPsiNodes = 65;

struct PsiWindowSettings {
  model::PsiWindowRule rule;  // Q, the half width in sd, when to narrow or move
  // Q while the window is the whole prior box, piecewise linear there (model::PsiGrid::kLinear).
  // The window leaves the box once mean ± 6 sd spans under half of it, so the spacing h is then
  // box / (Q - 1) against an sd of box / 24 at most: the chords err by at most (24 / (Q - 1))² / 8
  // nats summed over the trucks, 0.28 at Q = 17. The box phase only has to put the first window in
  // the right place (every table is rebuilt on it and the change tempered in).
  int box_nodes = 17;
};

// The nodes a window has: box_nodes on the whole box, else the rule's; and its grid (piecewise
// linear on the whole box, Chebyshev on a window inside it).
int psi_window_nodes(const PsiWindowSettings& s, const model::PsiWindow& w, double box_lo, double box_hi);
model::PsiGrid psi_window_grid(const model::PsiWindow& w, int nodes, double box_lo, double box_hi);

// The ψ posterior's weighted mean and sd over a cloud (row 0 of psi), the sd floored at 1e-9 of
// the box so a collapsed cloud still gives a window.
struct PsiMoments {
  double mean = 0.0, sd = 0.0;
};
PsiMoments psi_moments(const Eigen::MatrixXd& psi, const Eigen::ArrayXd& W, double box_lo, double box_hi);

// Σ_q L_q(ψ) values[q * stride] on a grid: -inf outside the window, or where a node's value
// with a non-zero weight is -inf or NaN (a node sum at a θ no table supports).
double interpolate_node_sums(const model::PsiGrid& grid, double psi, const double* values,
                             std::size_t stride);
double interpolate_node_sums(const model::PsiGrid& grid, double psi, const util::ExactSum* sums,
                             std::size_t stride);

}  // namespace ssrfleet::fleet
