// The exact per-truck marginal likelihood that table_error_benchmark measures the tables against:
//   ℓ_i(θ) = (M/2) log(u / 2π) + log ∫∫ N(k | K, σ_k²) N(k_t | K_t, σ_kt²) X(k, k_t; θ) dk dk_t,
//   X = ∫_road exp(-u SSR(k, k_t, z) / 2) N(z | Z, σ_z²) / P_road dz.
// The z-integral is done in closed form: between two lateral lines the impact factors are linear
// in z, so on each segment the integrand is exp(quadratic in z) and integrates to error
// functions; the whole road width is summed, not a window. The (k, k_t) integral is the
// rectangle rule on a lattice flooded out to `threshold_nats` below the integrand's peak for
// every draw θ_d at once (spectrally accurate once the spacing is below the integrand's width;
// the benchmark checks it by refining). One node costs one integrator pass per road line and is
// reused for every θ_d, so many draws cost no more passes.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "model/fleet_marginal.hpp"
#include "model/fleet_model.hpp"
#include "model/truck_search.hpp"
#include "model/truck_table.hpp"
#include "site/site.hpp"
#include "util/gauss_legendre.hpp"
#include "util/parallel_range.hpp"

namespace ssrfleet::bench::table_error {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// What one θ draw contributes to every node: the z- and σ_IF parts.
struct Draw {
  fleet::HyperVector theta;
  double u = 0.0, log_u = 0.0;
  double log_mass = 0.0;  // log P_road(Z, σ_z)
};

inline Draw make_draw(const fleet::HyperVector& theta, double lo_m, double hi_m) {
  Draw d;
  d.theta = theta;
  d.u = 1.0 / (theta[fleet::kSigmaIf] * theta[fleet::kSigmaIf]);
  d.log_u = std::log(d.u);
  d.log_mass = fleet::log_normal_mass(lo_m, hi_m, theta[fleet::kZ], theta[fleet::kSigmaZ]);
  return d;
}

inline double log_add(double a, double b) {
  if (a == kNegInf) return b;
  if (b == kNegInf) return a;
  const double m = std::max(a, b);
  return m + std::log(std::exp(a - m) + std::exp(b - m));
}

// Mills ratio Φc(x) / φ(x) for x >= 8 by its continued fraction (converges in a few terms there).
inline double mills_ratio(double x) {
  double f = x;
  for (int k = 40; k >= 1; --k) f = x + k / f;
  return 1.0 / f;
}

// log ∫_0^1 exp(-½ (A w² - 2 B w + C)) dw, A >= 0, stable for every A, B, C the segments produce.
inline double log_segment_integral(double A, double B, double C) {
  auto f = [&](double w) { return -0.5 * (A * w * w - 2.0 * B * w + C); };
  // The integrand's peak on [0, 1].
  const double vertex = A > 0.0 ? B / A : (B > 0.0 ? 1.0 : 0.0);
  const double w_star = std::clamp(vertex, 0.0, 1.0);
  const double top = f(w_star);
  static const util::QuadratureRule rule = util::gauss_legendre01(32);
  if (A < 1e-3) {
    // Nearly linear in w: Gauss–Legendre on the part of [0, 1] within 60 nats of the peak.
    const double slope = std::abs(B - A * w_star);  // |f'| at the peak side (0 inside)
    const double reach = slope > 0.0 ? std::min(1.0, 60.0 / slope) : 1.0;
    double lo = 0.0, hi = 1.0;
    if (w_star <= 0.0) hi = reach;
    if (w_star >= 1.0) lo = 1.0 - reach;
    double s = 0.0;
    for (std::size_t p = 0; p < rule.nodes.size(); ++p) {
      const double w = lo + (hi - lo) * rule.nodes[p];
      s += rule.weights[p] * (hi - lo) * std::exp(f(w) - top);
    }
    return top + std::log(s);
  }
  const double s = std::sqrt(A);
  if (vertex >= 0.0 && vertex <= 1.0) {
    // Φ((1 - μ) s) - Φ(-μ s) as a sum of two non-negative erf terms.
    const double j = std::sqrt(2.0 * std::numbers::pi / A) * 0.5 *
                     (std::erf((1.0 - vertex) * s / std::numbers::sqrt2) + std::erf(vertex * s / std::numbers::sqrt2));
    return top + std::log(j);
  }
  // The vertex lies outside: from the nearer end e inwards, exp(-½ A t² - κ t), t in [0, 1].
  const double kappa = A * std::abs(vertex - w_star);
  const double x = kappa / s;
  double j;
  if (x < 8.0) {
    const double phic = [](double v) { return 0.5 * std::erfc(v / std::numbers::sqrt2); }(x);
    const double phic2 = 0.5 * std::erfc((x + s) / std::numbers::sqrt2);
    j = std::sqrt(2.0 * std::numbers::pi / A) * std::exp(0.5 * x * x) * (phic - phic2);
  } else {
    j = (mills_ratio(x) - std::exp(-x * s - 0.5 * A) * mills_ratio(x + s)) / s;
  }
  return top + std::log(j);
}

// One truck's exact node values: per lattice node and draw, X (with the lateral prior) and X0
// (without: log ∫_road exp(-u SSR / 2) dz).
class TruckReference {
 public:
  struct NodeValues {
    std::vector<double> x, x0;
    // With moments: the node's z-posterior mean and variance without the lateral prior, whole road,
    // at each draw's u; and at u_ref with their u-derivatives (what a table could store per entry).
    std::vector<double> z_mean, z_var;
    double z_mean_ref = 0.0, z_var_ref = 0.0, dz_mean_du = 0.0, dz_var_du = 0.0;
  };

  TruckReference(const site::Site& site, double speed_mps, double mass_kg, Eigen::VectorXd y,
                 const std::vector<Draw>& draws, util::ParallelRange parallel)
      : site_(site), speed_(speed_mps), mass_(mass_kg), y_(std::move(y)), draws_(draws), parallel_(std::move(parallel)),
        lines_(site.line_bundle(0, site.surface().lines())) {}

  long long passes() const { return passes_; }

  // Node values at (k[i], kt[i]).
  // u_ref > 0: also the z-moments (NodeValues), by differences of the log-integral tilted by exp(t z).
  std::vector<NodeValues> evaluate(const std::vector<double>& k, const std::vector<double>& kt, bool with_x0,
                                   double u_ref = 0.0) {
    const road::Surface& surface = site_.surface();
    const Eigen::Index L = surface.lines();
    const Eigen::ArrayXXd ifs = model::detail::simulate_on_lines(site_, speed_, mass_, k, kt, lines_, parallel_);
    passes_ += static_cast<long long>(k.size()) * L;
    std::vector<NodeValues> out(k.size());
    const double dy = surface.dy_m, log_dy = std::log(dy);
    parallel_(static_cast<Eigen::Index>(k.size()), [&](Eigen::Index begin, Eigen::Index end) {
      std::vector<double> aa(static_cast<std::size_t>(L - 1)), ad(aa.size()), dd(aa.size());
      for (Eigen::Index n = begin; n < end; ++n) {
        const auto block = ifs.middleCols(n * L, L);
        for (Eigen::Index j = 0; j + 1 < L; ++j) {
          const Eigen::VectorXd ea = y_ - block.col(j).matrix();
          const Eigen::VectorXd d = (block.col(j + 1) - block.col(j)).matrix();
          aa[static_cast<std::size_t>(j)] = ea.squaredNorm();
          ad[static_cast<std::size_t>(j)] = ea.dot(d);
          dd[static_cast<std::size_t>(j)] = d.squaredNorm();
        }
        NodeValues& v = out[static_cast<std::size_t>(n)];
        v.x.assign(draws_.size(), kNegInf);
        if (with_x0) v.x0.assign(draws_.size(), kNegInf);
        for (std::size_t d = 0; d < draws_.size(); ++d) {
          const Draw& dr = draws_[d];
          const double u = dr.u, Z = dr.theta[fleet::kZ], sz = dr.theta[fleet::kSigmaZ];
          const double inv_v = 1.0 / (sz * sz);
          double x = kNegInf, x0 = kNegInf;
          for (std::size_t j = 0; j < aa.size(); ++j) {
            const double t0 = surface.lateral_m(static_cast<Eigen::Index>(j)) - Z;
            const double A = u * dd[j] + dy * dy * inv_v;
            const double B = u * ad[j] - t0 * dy * inv_v;
            const double C = u * aa[j] + t0 * t0 * inv_v;
            x = log_add(x, log_segment_integral(A, B, C));
            if (with_x0) x0 = log_add(x0, log_segment_integral(u * dd[j], u * ad[j], u * aa[j]));
          }
          v.x[d] = x + log_dy - 0.5 * (fleet::kLog2Pi + std::log(sz * sz)) - dr.log_mass;
          if (with_x0) v.x0[d] = x0 + log_dy;
        }
        if (u_ref > 0.0) {
          // F(t) = log ∫ exp(-u SSR / 2 + t z) dz: F'(0) = E[z], F''(0) = Var[z].
          auto tilted = [&](double u, double t) {
            double f = kNegInf;
            for (std::size_t j = 0; j < aa.size(); ++j) {
              const double z0 = surface.lateral_m(static_cast<Eigen::Index>(j));
              f = log_add(f, log_segment_integral(u * dd[j], u * ad[j] + t * dy, u * aa[j] - 2.0 * t * z0));
            }
            return f;
          };
          auto moments = [&](double u) {
            constexpr double h = 0.1;
            const double fm = tilted(u, -h), f0 = tilted(u, 0.0), fp = tilted(u, h);
            return std::pair{(fp - fm) / (2.0 * h), (fp - 2.0 * f0 + fm) / (h * h)};
          };
          for (const Draw& dr : draws_) {
            const auto [mean, var] = moments(dr.u);
            v.z_mean.push_back(mean);
            v.z_var.push_back(var);
          }
          const double du = 0.01 * u_ref;
          const auto [m0, v0] = moments(u_ref);
          const auto [m1, v1] = moments(u_ref + du);
          const auto [m2, v2] = moments(u_ref - du);
          v.z_mean_ref = m0;
          v.z_var_ref = v0;
          v.dz_mean_du = (m1 - m2) / (2.0 * du);
          v.dz_var_du = (v1 - v2) / (2.0 * du);
        }
      }
    });
    return out;
  }

  // The rectangle rule on `lattice` flooded from `seeds` out to threshold_nats below every
  // draw's best node: node -> values. `floor_sd` evaluates the fleet sds at FleetMarginal's floor
  // (as the tables do on their own lattice).
  using NodeMap = std::map<std::pair<int, int>, NodeValues>;
  NodeMap flood(const model::Lattice& lattice, std::vector<std::pair<int, int>> seeds, double threshold_nats,
                bool floor_sd, bool with_x0, double u_ref = 0.0) {
    NodeMap nodes;
    std::vector<double> best(draws_.size(), kNegInf);
    auto admissible = [&](int i, int j) { return lattice.k_at(i) > 0.0 && lattice.kt_at(j) > 0.0; };
    auto score = [&](const std::pair<int, int>& ij, const NodeValues& v, std::size_t d) {
      return log_prior(lattice, ij, draws_[d].theta, floor_sd) + v.x[d];
    };
    std::vector<std::pair<int, int>> pending;
    for (const auto& s : seeds)
      if (admissible(s.first, s.second) && std::find(pending.begin(), pending.end(), s) == pending.end())
        pending.push_back(s);
    for (int round = 0; !pending.empty() && round < 400; ++round) {
      std::vector<double> k, kt;
      for (const auto& [i, j] : pending) {
        k.push_back(lattice.k_at(i));
        kt.push_back(lattice.kt_at(j));
      }
      std::vector<NodeValues> values = evaluate(k, kt, with_x0, u_ref);
      for (std::size_t p = 0; p < pending.size(); ++p) {
        for (std::size_t d = 0; d < draws_.size(); ++d) best[d] = std::max(best[d], score(pending[p], values[p], d));
        nodes[pending[p]] = std::move(values[p]);
      }
      std::vector<std::pair<int, int>> next;
      for (const auto& [ij, v] : nodes) {
        bool inside = false;
        for (std::size_t d = 0; d < draws_.size() && !inside; ++d) inside = score(ij, v, d) >= best[d] - threshold_nats;
        if (!inside) continue;
        for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const std::pair<int, int> nb{ij.first + di, ij.second + dj};
          if (!admissible(nb.first, nb.second) || nodes.count(nb) || std::find(next.begin(), next.end(), nb) != next.end())
            continue;
          next.push_back(nb);
        }
      }
      pending.swap(next);
    }
    return nodes;
  }

  // log N(k_g | K, σ_k²) N(kt_g | K_t, σ_kt²) (sds floored as FleetMarginal floors them, if asked).
  static double log_prior(const model::Lattice& lattice, const std::pair<int, int>& ij, const fleet::HyperVector& t,
                          bool floor_sd) {
    double sk = t[fleet::kSigmaK], skt = t[fleet::kSigmaKt];
    if (floor_sd) {
      sk = std::max(sk, model::FleetMarginal::kMinSdPerSpacing * lattice.dk_npm);
      skt = std::max(skt, model::FleetMarginal::kMinSdPerSpacing * lattice.dkt_npm);
    }
    return fleet::log_normal_density(lattice.k_at(ij.first), t[fleet::kK], sk) +
           fleet::log_normal_density(lattice.kt_at(ij.second), t[fleet::kKt], skt);
  }

 private:
  const site::Site& site_;
  double speed_, mass_;
  Eigen::VectorXd y_;
  const std::vector<Draw>& draws_;
  util::ParallelRange parallel_;
  vehicle::LineBundle lines_;
  long long passes_ = 0;
};

}  // namespace ssrfleet::bench::table_error
