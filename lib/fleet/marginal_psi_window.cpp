#include "fleet/marginal_psi_window.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace ssrfleet::fleet {

namespace {
constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// How far the interpolant may rise above its highest node: a share of the nodes' spread (max - min),
// and at most a few nats. A smooth ℓ(ψ) rises less: a concave quadratic on Q = 5 Chebyshev nodes
// peaks at most 0.022 of the spread above its best node (the nodes' widest gap is 0.29 of the
// window, and the farthest node at least half the window away), so under 2 nats wherever the nodes
// span under 90 nats, as they do across the window near the posterior (it spans ±6 posterior sd,
// about 18 nats at its edges). A polynomial through nodes that span thousands of nats (a θ far from
// the posterior, where ℓ changes steeply with ψ, e.g. small σ_IF under a sensor's gain) swings far
// above every node in between. A target that rises without bound there draws the tempering's
// particles away and stalls it (a 4-truck fit with a 1.05 gain took temperature steps of 1e-9);
// one that rises hundreds of nats (the share alone: 5 % of 1e4) makes a false mode the cloud can
// settle in (a 4-truck suspension_damping fit then met its 4th truck at ℓ = -2.6e10).
constexpr double kMaxRiseShare = 0.05;
constexpr double kMaxRiseNats = 2.0;

template <class Value>
double interpolate(const model::PsiGrid& grid, double psi, const Value& value_at) {
  if (!grid.contains(psi)) return kNegInf;
  std::array<double, kMaxPsiNodes> w{};
  grid.weights(psi, w.data());
  double s = 0.0;
  double top = kNegInf, bottom = -kNegInf;
  for (int q = 0; q < grid.size(); ++q) {
    if (w[static_cast<std::size_t>(q)] == 0.0) continue;  // at a node the others' weights are exactly 0
    const double v = value_at(static_cast<std::size_t>(q));
    if (!std::isfinite(v)) return kNegInf;
    s += w[static_cast<std::size_t>(q)] * v;
    top = std::max(top, v);
    bottom = std::min(bottom, v);
  }
  return std::min(s, top + std::min(kMaxRiseShare * (top - bottom), kMaxRiseNats));
}
}  // namespace

bool carried_by_psi_window(const ModelExtension* e) {
  return e != nullptr && e->edits_forward() && e->dim() == 1 && !e->adds_profile() && e->jump_draws() == 0 &&
         e->stiffness_jump_draws() == 0 && !e->edits_stiffness_distribution();
}

bool psi_window_by_default(const ModelExtension* e) {
  return carried_by_psi_window(e) && e->name() != "speed_bias";
}

int psi_window_nodes(const PsiWindowSettings& s, const model::PsiWindow& w, double box_lo, double box_hi) {
  return w.lo <= box_lo && w.hi >= box_hi ? s.box_nodes : s.rule.nodes;
}

model::PsiGrid psi_window_grid(const model::PsiWindow& w, int nodes, double box_lo, double box_hi) {
  const bool box = w.lo <= box_lo && w.hi >= box_hi;
  return model::PsiGrid(w.lo, w.hi, nodes,
                        box ? model::PsiGrid::Kind::kLinear : model::PsiGrid::Kind::kChebyshev);
}

PsiMoments psi_moments(const Eigen::MatrixXd& psi, const Eigen::ArrayXd& W, double box_lo, double box_hi) {
  const Eigen::ArrayXd x = psi.row(0).transpose().array();
  const double mean = (W * x).sum() / W.sum();
  const double var = (W * (x - mean).square()).sum() / W.sum();
  return {mean, std::max(std::sqrt(std::max(var, 0.0)), 1e-9 * (box_hi - box_lo))};
}

double interpolate_node_sums(const model::PsiGrid& grid, double psi, const double* values,
                             std::size_t stride) {
  return interpolate(grid, psi, [&](std::size_t q) { return values[q * stride]; });
}

double interpolate_node_sums(const model::PsiGrid& grid, double psi, const util::ExactSum* sums,
                             std::size_t stride) {
  return interpolate(grid, psi, [&](std::size_t q) { return sums[q * stride].value(); });
}

}  // namespace ssrfleet::fleet
