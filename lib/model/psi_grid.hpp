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
// Where the interval sits. Early the ψ posterior fills the prior box; later the window is the
// posterior mean ± half_width_sd posterior sd, clipped to the box. As the posterior narrows, the
// tables already built stay valid (their window still holds the posterior; a wider window only
// errs more per truck, and the earlier trucks are few), so only new trucks need the narrower
// window: the sum over trucks of the per-window errors then stays bounded without rebuilding old
// tables. Tables must be rebuilt only when the posterior has moved so that it is no longer well
// inside their window.
#pragma once

#include <vector>

namespace ssrfleet::model {

// Two kinds of grid. kChebyshev: the polynomial through Q Chebyshev points (above), accurate where
// ℓ_i is smooth over [a, b] (a window of a few posterior sd). kLinear: Q evenly spaced nodes and the
// piecewise-linear interpolant (L_q the hat function of node q, at most two non-zero), for a range
// as wide as the prior box, where ℓ_i(ψ) of a single truck can be far from a polynomial (a
// polynomial through it there swings by nats between nodes) but a chord between neighbouring nodes
// errs by at most h² max|ℓ''| / 8, h the spacing: a fraction of a nat while h is under the
// posterior sd of ψ.
class PsiGrid {
 public:
  enum class Kind { kChebyshev, kLinear };
  // Q nodes on [lo, hi]: Chebyshev points of the second kind for Q >= 2, the midpoint for Q = 1;
  // or (kLinear, Q >= 2) lo + (hi - lo) q / (Q - 1). UsageError unless lo < hi and Q >= 1.
  PsiGrid(double lo, double hi, int nodes, Kind kind = Kind::kChebyshev);

  double lo() const { return lo_; }
  double hi() const { return hi_; }
  int size() const { return static_cast<int>(nodes_.size()); }
  const std::vector<double>& nodes() const { return nodes_; }
  bool contains(double psi) const { return psi >= lo_ && psi <= hi_; }
  Kind kind() const { return kind_; }

  // The Lagrange weights L_q(ψ), q = 0..Q-1, into out[0..Q-1]. At a node, that node's weight is 1
  // and the others 0 exactly.
  void weights(double psi, double* out) const;
  std::vector<double> weights(double psi) const;
  // Σ_q L_q(ψ) values[q].
  double interpolate(const double* values, double psi) const;

 private:
  double lo_, hi_;
  Kind kind_;
  std::vector<double> nodes_, barycentric_;
};

// How the interval and Q follow the ψ posterior.
struct PsiWindowRule {
  int nodes = 5;               // Q
  double half_width_sd = 6.0;  // the window is mean ± this many posterior sd (clipped to the box)
  // New trucks get a new window when the ideal one is narrower than this fraction of the current
  // one (the posterior has narrowed: a Q-node interpolant's error grows like width^Q).
  double too_wide = 0.5;
  // Tables on a window must be rebuilt when mean ± this many sd is no longer inside it (the
  // posterior has moved: the interpolant is then near, or past, its ends).
  double inner_sd = 4.0;
};

struct PsiWindow {
  double lo = 0.0, hi = 0.0;
};

// The window the rule puts round a posterior (mean, sd) inside the prior box [box_lo, box_hi]. A
// posterior as broad as the box gets the box. UsageError unless box_lo < box_hi and sd > 0.
PsiWindow psi_window(const PsiWindowRule& rule, double mean, double sd, double box_lo, double box_hi);

// What a window of tables means for the posterior (mean, sd): keep it; narrowed (the ideal window
// is under too_wide × its width: new trucks should get psi_window(), the tables on it stay); or
// moved (mean ± inner_sd sd leaves it, where the box allows more: the tables on it must be rebuilt).
enum class PsiWindowCheck { kKeep, kNarrowed, kMoved };
PsiWindowCheck check_psi_window(const PsiWindowRule& rule, const PsiWindow& current, double mean, double sd,
                                double box_lo, double box_hi);

}  // namespace ssrfleet::model
