#include "model/psi_grid.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "util/errors.hpp"

namespace ssrfleet::model {

PsiGrid::PsiGrid(double lo, double hi, int nodes, Kind kind) : lo_(lo), hi_(hi), kind_(kind) {
  if (!(lo < hi))
    throw UsageError("psi grid: the interval [" + std::to_string(lo) + ", " + std::to_string(hi) +
                     "] is empty");
  if (nodes < 1) throw UsageError("psi grid: needs at least one node");
  const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  if (nodes == 1) {
    nodes_ = {mid};
    barycentric_ = {1.0};
    return;
  }
  const int n = nodes - 1;
  if (kind == Kind::kLinear) {
    for (int q = 0; q <= n; ++q) nodes_.push_back(q == n ? hi : lo + (hi - lo) * q / n);
    return;
  }
  for (int q = 0; q <= n; ++q) {
    // The ends exactly (cos(0), cos(π) rounded would miss them by an ulp); the middle node of an
    // odd Q exactly at the midpoint, so the grid is symmetric.
    double x;
    if (q == 0)
      x = lo;
    else if (q == n)
      x = hi;
    else if (2 * q == n)
      x = mid;
    else
      x = mid - half * std::cos(std::numbers::pi * q / n);
    nodes_.push_back(x);
    double w = (q % 2 == 0) ? 1.0 : -1.0;
    if (q == 0 || q == n) w *= 0.5;
    barycentric_.push_back(w);
  }
}

void PsiGrid::weights(double psi, double* out) const {
  const std::size_t q = nodes_.size();
  if (kind_ == Kind::kLinear && q >= 2) {
    // The hat functions: the two nodes either side of ψ (clamped to the ends outside [lo, hi]).
    std::fill(out, out + q, 0.0);
    const double x = std::clamp(psi, lo_, hi_);
    std::size_t j = std::upper_bound(nodes_.begin(), nodes_.end(), x) - nodes_.begin();
    j = std::clamp<std::size_t>(j, 1, q - 1);
    const double t = (x - nodes_[j - 1]) / (nodes_[j] - nodes_[j - 1]);
    out[j - 1] = 1.0 - t;
    out[j] = t;
    return;
  }
  for (std::size_t j = 0; j < q; ++j) {
    if (psi == nodes_[j]) {
      std::fill(out, out + q, 0.0);
      out[j] = 1.0;
      return;
    }
  }
  double sum = 0.0;
  for (std::size_t j = 0; j < q; ++j) {
    out[j] = barycentric_[j] / (psi - nodes_[j]);
    sum += out[j];
  }
  for (std::size_t j = 0; j < q; ++j) out[j] /= sum;
}

std::vector<double> PsiGrid::weights(double psi) const {
  std::vector<double> w(nodes_.size());
  weights(psi, w.data());
  return w;
}

double PsiGrid::interpolate(const double* values, double psi) const {
  std::vector<double> w = weights(psi);
  double s = 0.0;
  for (std::size_t j = 0; j < w.size(); ++j) s += w[j] * values[j];
  return s;
}

PsiWindow psi_window(const PsiWindowRule& rule, double mean, double sd, double box_lo, double box_hi) {
  if (!(box_lo < box_hi)) throw UsageError("psi window: the prior box is empty");
  if (!(sd > 0.0)) throw UsageError("psi window: the posterior sd must be positive");
  const double half = rule.half_width_sd * sd;
  PsiWindow w{std::max(box_lo, mean - half), std::min(box_hi, mean + half)};
  // A mean outside the box (a posterior piled against an end): the window at that end.
  if (!(w.lo < w.hi)) {
    const double width = std::min(box_hi - box_lo, 2.0 * half);
    w = mean <= box_lo ? PsiWindow{box_lo, box_lo + width} : PsiWindow{box_hi - width, box_hi};
  }
  return w;
}

PsiWindowCheck check_psi_window(const PsiWindowRule& rule, const PsiWindow& current, double mean, double sd,
                                double box_lo, double box_hi) {
  const PsiWindow ideal = psi_window(rule, mean, sd, box_lo, box_hi);
  const double inner = rule.inner_sd * sd;
  const double need_lo = std::max(box_lo, mean - inner), need_hi = std::min(box_hi, mean + inner);
  if (need_lo < current.lo || need_hi > current.hi) return PsiWindowCheck::kMoved;
  if (ideal.hi - ideal.lo < rule.too_wide * (current.hi - current.lo)) return PsiWindowCheck::kNarrowed;
  return PsiWindowCheck::kKeep;
}

}  // namespace ssrfleet::model
