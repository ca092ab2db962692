// Interpolation of a truck's likelihood in a one-parameter model extension's ψ.
//
// A table (truck_table.hpp) holds ℓ_i(θ, ψ) at one fixed ψ. Effects that act inside the dynamics
// (a vehicle constant, the speed) move the impact factors smoothly in ψ, so ℓ_i is smooth in ψ
// and can be carried by tables at Q nodes ψ_1..ψ_Q of an interval [a, b] and the polynomial
// through them:
//   ℓ_i(θ, ψ) ≈ Σ_q L_q(ψ) ℓ_i(θ, ψ_q),
// L_q the Lagrange basis. The nodes are Chebyshev points of the second kind (the extrema of T_{Q-1},
// ends included): x_q = (a + b)/2 - (b - a)/2 cos(π q / (Q - 1)), q = 0..Q-1, ascending. On them
// the interpolant's error for an analytic function falls geometrically in Q, and the barycentric
// form
//   L_q(ψ) = (w_q / (ψ - x_q)) / Σ_j (w_j / (ψ - x_j)),   w_q = (-1)^q, halved at both ends,
// is numerically stable for every ψ in [a, b] (Berrut & Trefethen 2004). It reproduces every
// polynomial of degree < Q exactly, and Σ_q L_q(ψ) = 1 at every ψ (a constant offset in ℓ_i is
// carried unchanged). Outside [a, b] the same formula extrapolates, with an error that grows fast:
// callers keep ψ inside (contains()). The interval may be in any smooth coordinate of ψ (the
// grid only sees numbers): log ψ spreads the nodes where a likelihood changes fastest near the low
// end of a positive box.
//
// Where the interval sits. Early the ψ posterior fills the prior box, so the interval is the box;
// later it is the posterior mean ± half_width_sd posterior sd, clipped to the box. The window is
// rebuilt (new tables at new nodes) when the posterior has left it or narrowed well inside it,
// checked at the same geometrically spaced truck counts as the (k, k_t) lattice (rebuild_growth),
// so the rebuilds cost O(1) per truck.
#pragma once

#include <vector>

namespace ssrfleet::model {

class PsiGrid {
 public:
  // Q nodes on [lo, hi]: Chebyshev points of the second kind for Q >= 2, the midpoint for Q = 1.
  // UsageError unless lo < hi and Q >= 1.
  PsiGrid(double lo, double hi, int nodes);

  double lo() const { return lo_; }
  double hi() const { return hi_; }
  int size() const { return static_cast<int>(nodes_.size()); }
  const std::vector<double>& nodes() const { return nodes_; }
  bool contains(double psi) const { return psi >= lo_ && psi <= hi_; }

  // The Lagrange weights L_q(ψ), q = 0..Q-1, into out[0..Q-1]. At a node, that node's weight is 1
  // and the others 0 exactly.
  void weights(double psi, double* out) const;
  std::vector<double> weights(double psi) const;
  // Σ_q L_q(ψ) values[q].
  double interpolate(const double* values, double psi) const;

 private:
  double lo_, hi_;
  std::vector<double> nodes_, barycentric_;
};

// How the interval and Q follow the ψ posterior.
struct PsiWindowRule {
  int nodes = 5;               // Q
  double half_width_sd = 6.0;  // the window is mean ± this many posterior sd (clipped to the box)
  // Rebuild when the ideal window is narrower than this fraction of the current one (the
  // posterior has narrowed: the nodes are spread wider than they need be) ...
  double too_wide = 0.5;
  // ... or when mean ± this many sd is no longer inside the current window (the posterior has
  // moved: the interpolant is then near, or past, its ends).
  double inner_sd = 4.0;
};

struct PsiWindow {
  double lo = 0.0, hi = 0.0;
};

// The window the rule puts round a posterior (mean, sd) inside the prior box [box_lo, box_hi]. A
// posterior as broad as the box gets the box. UsageError unless box_lo < box_hi and sd > 0.
PsiWindow psi_window(const PsiWindowRule& rule, double mean, double sd, double box_lo, double box_hi);

// Whether a grid on `current` should be rebuilt for the posterior (mean, sd): it has moved so that
// mean ± inner_sd sd leaves `current` (where the box allows more), or it has narrowed so that the
// ideal window is narrower than too_wide × current's width.
bool psi_window_needs_rebuild(const PsiWindowRule& rule, const PsiWindow& current, double mean, double sd,
                              double box_lo, double box_hi);

}  // namespace ssrfleet::model
