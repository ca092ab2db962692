#include "model/truck_table.hpp"

#include "model/node_z_integral.hpp"
#include "model/truck_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <utility>

#include <Eigen/Dense>

#include "model/fleet_model.hpp"
#include "util/errors.hpp"
#include "util/gauss_legendre.hpp"

namespace ssrfleet::model {

using detail::check_inputs;
using detail::Fitter;
using detail::Point;
using detail::simulate;
using detail::simulate_on_lines;

using detail::integrate_node;
using detail::lateral_gaussian_form;
using detail::NodeResult;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace


std::size_t TruckTable::bytes() const {
  return sizeof(TruckTable) + k_index.capacity() * sizeof(std::int32_t) * 2 +
         (c.capacity() + m.capacity() + b.capacity() + z_mean_m.capacity() + z_var_m2.capacity() +
          z_mean_slope_m.capacity() + z_var_slope_m2.capacity()) * sizeof(float);
}

TruckTable build_truck_table(const site::Site& site, double speed_mps, double sprung_mass_kg,
                             const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const Lattice& lattice,
                             const TruckTableOptions& options) {
  const TruckFit fit = fit_truck(site, speed_mps, sprung_mass_kg, impact_factors, options);
  return build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, lattice, options, fit);
}

TruckTable build_truck_table(const site::Site& site, double speed_mps, double sprung_mass_kg,
                             const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const Lattice& lattice,
                             const TruckTableOptions& options, const TruckFit& fit) {
  return build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, lattice, options, fit, util::serial_range);
}

TruckTable build_truck_table(const site::Site& site, double speed_mps, double sprung_mass_kg,
                             const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const Lattice& lattice,
                             const TruckTableOptions& options, const TruckFit& fit,
                             const util::ParallelRange& parallel) {
  check_inputs(site, impact_factors);
  if (!lattice.valid()) throw UsageError("truck table: the (k, k_t) lattice has a non-positive spacing");
  if (!(options.sigma_ref > 0.0)) throw UsageError("truck table: sigma_ref must be positive");
  const road::Surface& surface = site.surface();
  const double u_ref = 1.0 / (options.sigma_ref * options.sigma_ref);
  const util::QuadratureRule rule = util::gauss_legendre01(options.points_per_segment);
  const ForwardEdit* edit = detail::active_edit(options);

  // Lateral modes: scan the fit's (k, k_t) over every line of the road and keep the segments whose
  // least SSR is within keep_nats (at u_ref) of the best. Runs of such segments closer than
  // 2 z_margin_lines are one mode; each mode is tabulated on its own lines (widened by
  // z_margin_lines each side), so a truck whose z-likelihood has two modes across the road keeps
  // both (the z-integral splits over disjoint ranges: the node sum adds them exactly).
  const Eigen::Index L = surface.lines();
  int table_passes_extra = 0;
  std::vector<double> seg_min;
  {
    const Eigen::ArrayXXd ifs = simulate_on_lines(site, speed_mps, sprung_mass_kg, {fit.stiffness_npm},
                                                  {fit.tyre_stiffness_npm}, site.line_bundle(0, L), parallel, edit);
    for (Eigen::Index j = 0; j + 1 < L; ++j) {
      const Eigen::VectorXd ea = impact_factors - ifs.col(j).matrix();
      const Eigen::VectorXd d = (ifs.col(j + 1) - ifs.col(j)).matrix();
      const double aa = ea.squaredNorm(), ad = ea.dot(d), dd = d.squaredNorm();
      const double w = dd > 0.0 ? std::clamp(ad / dd, 0.0, 1.0) : 0.0;
      seg_min.push_back(std::max(0.0, aa - 2.0 * w * ad + w * w * dd));
    }
  }
  struct Mode {
    Eigen::Index first_line, last_line;
    double k_npm, kt_npm;
  };
  std::vector<Mode> modes;
  {
    const double best = seg_min.empty() ? 0.0 : *std::min_element(seg_min.begin(), seg_min.end());
    const double keep_limit = best + 2.0 * options.keep_nats / u_ref;
    // Runs of segments whose least SSR is below `limit`, closer than 2 z_margin_lines merged.
    auto runs_below = [&](double limit) {
      std::vector<std::pair<Eigen::Index, Eigen::Index>> runs;  // segment ranges [a, b]
      for (Eigen::Index j = 0; j < static_cast<Eigen::Index>(seg_min.size()); ++j) {
        if (seg_min[static_cast<std::size_t>(j)] > limit) continue;
        if (!runs.empty() && j - runs.back().second <= 2 * options.z_margin_lines + 1)
          runs.back().second = j;
        else
          runs.emplace_back(j, j);
      }
      return runs;
    };
    // How broad the truck's z-likelihood is at its fit (segment minima as weights).
    double w0 = 0.0, w1 = 0.0, w2 = 0.0;
    for (std::size_t j = 0; j < seg_min.size(); ++j) {
      const double w = std::exp(-0.5 * u_ref * (seg_min[j] - best));
      const double zc = surface.lateral_m(static_cast<Eigen::Index>(j)) + 0.5 * surface.dy_m;
      w0 += w;
      w1 += w * zc;
      w2 += w * zc * zc;
    }
    const bool broad = w0 > 0.0 && w2 / w0 - (w1 / w0) * (w1 / w0) > options.max_piece_sd_m * options.max_piece_sd_m;
    // The modes. Where z is broad, the runs within keep_nats + mode_margin_nats at the fit's
    // (k, k_t): away from the fit a node's z-likelihood reaches lines and whole modes that look
    // worse from the fit than they are (road AS2: 0.6 % of one truck's likelihood missed at a margin
    // of 0). Where z is pinned down (road AS1) the runs within keep_nats, as the margin would only
    // widen them (37 % more integrator passes per truck for no kept node), plus the runs within the
    // margin that touch none of them, each tabulated only if its own best fit is within keep_nats.
    std::vector<std::pair<Eigen::Index, Eigen::Index>> runs =
        runs_below(broad ? keep_limit + 2.0 * options.mode_margin_nats / u_ref : keep_limit);
    const std::size_t kept_runs = runs.size();
    if (!broad && options.mode_margin_nats > 0.0) {
      for (const auto& run : runs_below(keep_limit + 2.0 * options.mode_margin_nats / u_ref)) {
        // (run, not a structured binding: clang before 16 cannot capture a binding in a lambda.)
        const bool touches = std::any_of(runs.begin(), runs.begin() + static_cast<std::ptrdiff_t>(kept_runs),
                                         [&](const auto& r) { return run.first <= r.second && r.first <= run.second; });
        if (!touches) runs.push_back(run);
      }
    }
    const double fit_line = (fit.lateral_m - surface.y0_m) / surface.dy_m;
    Fitter fitter{site, speed_mps, sprung_mass_kg, impact_factors, 0, edit};
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const auto [a, b] = runs[r];
      Mode m{std::max<Eigen::Index>(0, a - options.z_margin_lines), std::min<Eigen::Index>(L - 1, b + 1 + options.z_margin_lines),
             fit.stiffness_npm, fit.tyre_stiffness_npm};
      if (fit_line < static_cast<double>(a) - 1.0 || fit_line > static_cast<double>(b) + 2.0) {
        // Another mode than the fit's: its own best (k, k_t), with z kept inside it.
        Eigen::Index jbest = a;
        for (Eigen::Index j = a; j <= b; ++j)
          if (seg_min[static_cast<std::size_t>(j)] < seg_min[static_cast<std::size_t>(jbest)]) jbest = j;
        const double z0 = surface.lateral_m(jbest) + 0.5 * surface.dy_m;
        const double lo = surface.lateral_m(a), hi = surface.lateral_m(b + 1);
        const Point p0{std::log(fit.stiffness_npm), std::log(fit.tyre_stiffness_npm), z0};
        const auto [p, ssr] = fitter.optimise(p0, fitter.ssr_at(p0), lo, hi);
        if (r >= kept_runs && ssr > keep_limit) continue;  // a margin run that is not a mode after all
        m.k_npm = std::exp(p.log_k);
        m.kt_npm = std::exp(p.log_kt);
      }
      modes.push_back(m);
    }
    if (modes.empty()) modes.push_back({0, L - 1, fit.stiffness_npm, fit.tyre_stiffness_npm});
    table_passes_extra = fitter.passes + static_cast<int>(L);
  }

  // Per mode: start with the nodes inside the likelihood ellipse of radius sqrt(2 keep) at σ_ref
  // (times the population's Gaussian if given), then grow by neighbours while a node above the
  // threshold has an unevaluated neighbour (the likelihood is not exactly elliptic in (k, k_t)).
  const double sk = fit.stiffness_sd_per_sigma * options.sigma_ref;
  const double skt = fit.tyre_stiffness_sd_per_sigma * options.sigma_ref;
  const double rho = std::clamp(fit.stiffness_correlation, -0.999, 0.999);
  Eigen::Matrix2d likelihood_cov;
  likelihood_cov << sk * sk, rho * sk * skt, rho * sk * skt, skt * skt;
  const auto& pop = options.population;
  auto population_log_density = [&](double k, double kt) {
    if (!pop) return 0.0;
    const double a = (k - pop->k_mean_npm) / pop->k_sd_npm, b = (kt - pop->kt_mean_npm) / pop->kt_sd_npm;
    return -0.5 * (a * a + b * b);
  };
  auto admissible = [&](int i, int j) { return lattice.k_at(i) > 0.0 && lattice.kt_at(j) > 0.0; };
  auto score = [&](const std::pair<int, int>& ij, const NodeResult& r) {
    return r.log_i_ref + population_log_density(lattice.k_at(ij.first), lattice.kt_at(ij.second));
  };
  const double radius2 = 2.0 * options.keep_nats;

  TruckTable table;
  table.fit = fit;
  table.passes = fit.passes + table_passes_extra;
  double best_score = -kInf, best_log_i = -kInf;
  // Per mode, per node: the node's pieces (one unless its z-likelihood is broad).
  std::vector<std::map<std::pair<int, int>, std::vector<NodeResult>>> evaluated_by_mode(modes.size());
  for (std::size_t mi = 0; mi < modes.size(); ++mi) {
    const Mode& mode = modes[mi];
    const Eigen::Index first_line = mode.first_line, lines = mode.last_line - mode.first_line + 1;
    // Every node of the mode runs on the same lines: read them once.
    const vehicle::LineBundle mode_lines = site.line_bundle(first_line, lines);
    Eigen::Matrix2d precision = likelihood_cov.inverse();
    Eigen::Vector2d centre(mode.k_npm, mode.kt_npm);
    if (pop) {
      Eigen::Matrix2d pop_precision = Eigen::Vector2d(1.0 / (pop->k_sd_npm * pop->k_sd_npm),
                                                      1.0 / (pop->kt_sd_npm * pop->kt_sd_npm)).asDiagonal();
      const Eigen::Vector2d rhs =
          precision * centre + pop_precision * Eigen::Vector2d(pop->k_mean_npm, pop->kt_mean_npm);
      precision += pop_precision;
      centre = precision.ldlt().solve(rhs);
    }
    const Eigen::Matrix2d region_cov = precision.inverse();
    const double ci = (centre[0] - lattice.k_origin_npm) / lattice.dk_npm;
    const double cj = (centre[1] - lattice.kt_origin_npm) / lattice.dkt_npm;
    const int ri = static_cast<int>(std::ceil(std::sqrt(radius2 * region_cov(0, 0)) / lattice.dk_npm)) + 1;
    const int rj = static_cast<int>(std::ceil(std::sqrt(radius2 * region_cov(1, 1)) / lattice.dkt_npm)) + 1;
    auto& evaluated = evaluated_by_mode[mi];
    std::vector<std::pair<int, int>> pending;
    for (int i = static_cast<int>(std::floor(ci)) - ri; i <= static_cast<int>(std::ceil(ci)) + ri; ++i) {
      for (int j = static_cast<int>(std::floor(cj)) - rj; j <= static_cast<int>(std::ceil(cj)) + rj; ++j) {
        if (!admissible(i, j)) continue;
        const Eigen::Vector2d d(lattice.k_at(i) - centre[0], lattice.kt_at(j) - centre[1]);
        if (d.dot(precision * d) <= radius2) pending.emplace_back(i, j);
      }
    }
    // Seed the node nearest the mode's own best fit too. The region above is only a Gaussian guess:
    // a ridge-shaped likelihood (k and k_t nearly interchangeable) combined with the population can
    // put its centre far off the fit, even at a negative stiffness (seen on road AS2), where no
    // node is admissible. The flood fill below grows from whatever scores above the threshold.
    {
      int fi = static_cast<int>(std::lround((mode.k_npm - lattice.k_origin_npm) / lattice.dk_npm));
      int fj = static_cast<int>(std::lround((mode.kt_npm - lattice.kt_origin_npm) / lattice.dkt_npm));
      while (!(lattice.k_at(fi) > 0.0)) ++fi;
      while (!(lattice.kt_at(fj) > 0.0)) ++fj;
      if (std::find(pending.begin(), pending.end(), std::pair{fi, fj}) == pending.end()) pending.emplace_back(fi, fj);
    }
    for (int round = 0; !pending.empty() && round < 50; ++round) {
      std::vector<double> k, kt;
      for (const auto& [i, j] : pending) {
        k.push_back(lattice.k_at(i));
        kt.push_back(lattice.kt_at(j));
      }
      const Eigen::ArrayXXd ifs = simulate_on_lines(site, speed_mps, sprung_mass_kg, k, kt, mode_lines, parallel, edit);
      table.passes += static_cast<int>(k.size() * static_cast<std::size_t>(lines));
      // Each node's z-integral is its own (in parallel, then gathered in order: the same bits).
      std::vector<std::vector<NodeResult>> results(pending.size());
      parallel(static_cast<Eigen::Index>(pending.size()), [&](Eigen::Index begin, Eigen::Index end) {
        for (Eigen::Index p = begin; p < end; ++p) {
          results[static_cast<std::size_t>(p)] =
              integrate_node(ifs.middleCols(p * lines, lines), first_line, surface, impact_factors, u_ref, rule,
                             options.max_piece_sd_m, options.lateral_check);
        }
      });
      for (std::size_t p = 0; p < pending.size(); ++p) {
        std::vector<NodeResult>& pieces = results[p];
        for (const NodeResult& r : pieces) {
          best_score = std::max(best_score, score(pending[p], r));
          best_log_i = std::max(best_log_i, r.log_i_ref);
        }
        evaluated[pending[p]] = std::move(pieces);
      }
      // A node's score: its best piece's.
      auto node_score = [&](const std::pair<int, int>& ij, const std::vector<NodeResult>& pieces) {
        double best = -kInf;
        for (const NodeResult& r : pieces) best = std::max(best, score(ij, r));
        return best;
      };
      const double threshold = best_score - options.keep_nats;
      std::vector<std::pair<int, int>> next;
      for (const auto& node : evaluated) {
        const auto& [ij, pieces] = node;
        const double here = node_score(ij, pieces);
        if (!(here >= threshold)) continue;
        for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const std::pair<int, int> nb{ij.first + di, ij.second + dj};
          if (!admissible(nb.first, nb.second) || evaluated.count(nb) ||
              std::find(next.begin(), next.end(), nb) != next.end())
            continue;
          // The ring beyond the kept region: a concave score (a log-likelihood in (k, k_t) near
          // Gaussian, plus the population's Gaussian) lies below its linear extrapolation, so a
          // neighbour whose extrapolation from this node and the one behind it falls ring_margin_nats
          // under the threshold would be evaluated only to be dropped. Another kept neighbour may
          // still ask for it.
          if (options.ring_margin_nats >= 0.0) {
            const auto behind = evaluated.find({ij.first - di, ij.second - dj});
            if (behind != evaluated.end() &&
                2.0 * here - node_score(behind->first, behind->second) < threshold - options.ring_margin_nats)
              continue;
          }
          next.push_back(nb);
        }
      }
      if (!next.empty() && round == 0) table.region_clipped = true;
      pending.swap(next);
    }
  }
  table.modes = static_cast<int>(modes.size());

  // Keep the pieces above the threshold; the truck's z-posterior variance is their weighted mean.
  auto for_each_kept = [&](const auto& body) {
    for (const auto& evaluated : evaluated_by_mode)
      for (const auto& [ij, pieces] : evaluated)
        for (const NodeResult& r : pieces)
          if (score(ij, r) >= best_score - options.keep_nats) body(ij, r);
  };
  double wsum = 0.0, var_sum = 0.0;
  int evaluated_nodes = 0;
  for (const auto& evaluated : evaluated_by_mode) evaluated_nodes += static_cast<int>(evaluated.size());
  for_each_kept([&](const std::pair<int, int>& ij, const NodeResult& r) {
    table.k_index.push_back(ij.first);
    table.kt_index.push_back(ij.second);
    table.c.push_back(static_cast<float>(r.c));
    table.m.push_back(static_cast<float>(r.m));
    table.b.push_back(static_cast<float>(r.b));
    table.z_mean_m.push_back(static_cast<float>(r.z_mean));
    table.z_var_m2.push_back(static_cast<float>(r.z_var));
    table.z_mean_slope_m.push_back(static_cast<float>(r.z_mean_slope));
    table.z_var_slope_m2.push_back(static_cast<float>(r.z_var_slope));
    const double w = std::exp(r.log_i_ref - best_log_i);
    wsum += w;
    var_sum += w * r.z_var;
  });
  table.z_var_ref_m2 = var_sum / wsum;
  if (options.lateral_check) {
    // log Σ_g w_g exp(d_g), w_g the kept piece's share at u_ref with the exact lateral term and the
    // fleet's predictive of (k, k_t), d_g = the Gaussian form minus the exact z-integral.
    const auto& ref = *options.lateral_check;
    std::vector<double> log_w, d;
    for_each_kept([&](const std::pair<int, int>& ij, const NodeResult& r) {
      log_w.push_back(score(ij, r) + r.lateral_exact);
      d.push_back(lateral_gaussian_form(r.z_mean, r.z_var, ref.mean_m, ref.sd_m) - r.lateral_exact);
    });
    const double top = *std::max_element(log_w.begin(), log_w.end());
    double num = 0.0, den = 0.0;
    for (std::size_t g = 0; g < d.size(); ++g) {
      const double w = std::exp(log_w[g] - top);
      num += w * std::exp(d[g]);
      den += w;
    }
    table.lateral_error_nats = std::log(num / den);
  }
  table.u_ref = u_ref;
  table.sensors = static_cast<int>(impact_factors.size());
  table.nodes_evaluated = evaluated_nodes;
  return table;
}

double reference_log_z_integral(const site::Site& site, double speed_mps, double sprung_mass_kg,
                                const Eigen::Ref<const Eigen::VectorXd>& impact_factors, double stiffness_npm,
                                double tyre_stiffness_npm, double sigma_if, double lateral_mean_m,
                                double lateral_sd_m, ZMoments* z_moments) {
  check_inputs(site, impact_factors);
  const road::Surface& surface = site.surface();
  const Eigen::Index L = surface.lines();
  std::vector<double> k(static_cast<std::size_t>(L), stiffness_npm), kt(static_cast<std::size_t>(L), tyre_stiffness_npm),
      z;
  for (Eigen::Index j = 0; j < L; ++j) z.push_back(surface.lateral_m(j));
  const Eigen::ArrayXXd ifs = simulate(site, speed_mps, sprung_mass_kg, k, kt, z);
  const double u = 1.0 / (sigma_if * sigma_if);
  // Fine composite rule: 8 sub-intervals of 16 points per segment, far beyond the table's.
  const util::QuadratureRule rule = util::gauss_legendre01(16);
  constexpr int kSub = 8;
  const double lo = site.lateral_min_m(), hi = site.lateral_max_m();
  const double mass = 0.5 * (std::erfc(-(hi - lateral_mean_m) / (lateral_sd_m * std::numbers::sqrt2)) -
                             std::erfc(-(lo - lateral_mean_m) / (lateral_sd_m * std::numbers::sqrt2)));
  std::vector<double> terms, at;
  for (Eigen::Index j = 0; j + 1 < L; ++j) {
    const Eigen::VectorXd ea = impact_factors - ifs.col(j).matrix();
    const Eigen::VectorXd d = (ifs.col(j + 1) - ifs.col(j)).matrix();
    const double aa = ea.squaredNorm(), ad = ea.dot(d), dd = d.squaredNorm();
    for (int s = 0; s < kSub; ++s) {
      for (std::size_t p = 0; p < rule.nodes.size(); ++p) {
        const double w = (s + rule.nodes[p]) / kSub;
        const double zz = surface.lateral_m(j) + w * surface.dy_m;
        const double ssr = std::max(0.0, aa - 2.0 * w * ad + w * w * dd);
        const double t = (zz - lateral_mean_m) / lateral_sd_m;
        terms.push_back(std::log(rule.weights[p] * surface.dy_m / kSub) - 0.5 * u * ssr - 0.5 * t * t -
                        std::log(lateral_sd_m * std::sqrt(2.0 * std::numbers::pi) * mass));
        at.push_back(zz);
      }
    }
  }
  const double top = *std::max_element(terms.begin(), terms.end());
  double sum = 0.0, first = 0.0, second = 0.0;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const double w = std::exp(terms[i] - top);
    sum += w;
    first += w * at[i];
    second += w * at[i] * at[i];
  }
  if (z_moments != nullptr) *z_moments = ZMoments{first / sum, second / sum};
  return top + std::log(sum);
}

}  // namespace ssrfleet::model
