// Internals shared by the best-fit search (truck_fit.cpp) and the table build (truck_table.cpp):
// batched integrator passes of one truck at many (k, k_t, z), and a Levenberg–Marquardt fitter.
// Not part of the model's interface.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "model/extended_forward.hpp"
#include "model/model_extension.hpp"
#include "model/truck_table.hpp"
#include "site/site.hpp"
#include "util/errors.hpp"
#include "util/parallel_range.hpp"

namespace ssrfleet::model::detail {

// The edit the passes run under, or null for the base model (none set, or an extension that
// edits nothing forward). UsageError if ψ does not match the extension.
inline const ForwardEdit* active_edit(const TruckTableOptions& options) {
  const ForwardEdit& e = options.forward;
  if (e.extension == nullptr || !e.extension->edits_forward()) return nullptr;
  if (static_cast<Eigen::Index>(e.psi.size()) != e.extension->dim())
    throw UsageError("truck table: extension " + e.extension->name() + " takes " + std::to_string(e.extension->dim()) +
                     " parameters, " + std::to_string(e.psi.size()) + " given");
  return &e;
}

// The passes of simulate() under an edit: the extended forward model (extended_forward.hpp).
inline void simulate_edited(const site::Site& site, double speed_mps, double sprung_mass_kg, const std::vector<double>& k,
                            const std::vector<double>& kt, const std::vector<double>& z, Eigen::Index begin,
                            Eigen::Index end, const ForwardEdit& edit, Eigen::Ref<Eigen::ArrayXXd> out) {
  std::vector<fleet::ExtendedPass> passes;
  passes.reserve(static_cast<std::size_t>(end - begin));
  for (Eigen::Index i = begin; i < end; ++i) {
    const auto u = static_cast<std::size_t>(i);
    passes.push_back({fleet::base_pass(site, speed_mps, sprung_mass_kg, k[u], kt[u], z[u]), edit.psi.data()});
  }
  fleet::simulate_passes(site, edit.extension, passes, out);
}

// simulate_on_lines()'s passes under an edit, nodes [begin, end): the pass edits go into each
// car's constants and the speed, so the lines stay bundled; an added profile's effect (the same
// on every line: the car is linear) is one more pass per node, added to each of its lines.
inline void simulate_on_lines_edited(const site::Site& site, double speed_mps, double sprung_mass_kg,
                                     const std::vector<double>& k, const std::vector<double>& kt,
                                     const vehicle::LineBundle& lines, Eigen::Index begin, Eigen::Index end,
                                     const ForwardEdit& edit, Eigen::Ref<Eigen::ArrayXXd> out) {
  const fleet::ModelExtension& ext = *edit.extension;
  const Eigen::Index n = end - begin, per_node = lines.lines();
  vehicle::QuarterCarBatch cars;
  cars.assign(n, vehicle::QuarterCar{});
  double speed = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(begin + i);
    const fleet::PassSetup base = fleet::base_pass(site, speed_mps, sprung_mass_kg, k[u], kt[u], 0.0);
    fleet::PassSetup s = base;
    ext.edit_pass(edit.psi.data(), s);
    if (s.lateral_m != base.lateral_m || (i > 0 && s.speed_mps != speed))
      throw UsageError("truck table: extension " + ext.name() +
                       " moves the lateral position or the speed per node, which line-bundled passes cannot run");
    speed = s.speed_mps;
    cars.set_car(i, fleet::quarter_car_of(s));
  }
  const vehicle::PassIntegrator& integrator = site.integrator();
  integrator.run_on_lines(cars, speed, lines, out);
  if (ext.adds_profile()) {
    Eigen::ArrayXd profile = Eigen::ArrayXd::Zero(integrator.samples());
    ext.add_profile(edit.psi.data(), integrator.dx_m(), profile);
    const std::vector<vehicle::WheelPath> paths(static_cast<std::size_t>(n), {profile.data(), profile.data(), 0.0});
    Eigen::ArrayXXd added(out.rows(), n);
    integrator.run_batch(cars, Eigen::ArrayXd::Constant(n, speed), paths, added);
    for (Eigen::Index i = 0; i < n; ++i)
      out.middleCols(i * per_node, per_node).colwise() += added.col(i) - 1.0;
  }
  for (Eigen::Index c = 0; c < out.cols(); ++c) ext.edit_output(edit.psi.data(), out.col(c));
}

// Impact factors (sensors x passes) of the trucks at the given (k, k_t, z): batched calls on
// chunks of the passes (each pass is independent, so the chunking changes no bit).
inline Eigen::ArrayXXd simulate(const site::Site& site, double speed_mps, double sprung_mass_kg,
                         const std::vector<double>& k, const std::vector<double>& kt, const std::vector<double>& z,
                         const util::ParallelRange& parallel = util::serial_range, const ForwardEdit* edit = nullptr) {
  const auto n = static_cast<Eigen::Index>(k.size());
  Eigen::ArrayXXd out(site.sensors(), n);
  // Chunks of whole integrator blocks; a small batch stays in one call.
  constexpr Eigen::Index kChunk = vehicle::batch_block_trucks;
  const Eigen::Index chunks = (n + kChunk - 1) / kChunk;
  parallel(chunks, [&](Eigen::Index cb, Eigen::Index ce) {
    const Eigen::Index begin = cb * kChunk, end = std::min(n, ce * kChunk);
    if (edit != nullptr) {
      if (end > begin) simulate_edited(site, speed_mps, sprung_mass_kg, k, kt, z, begin, end, *edit, out.middleCols(begin, end - begin));
      return;
    }
    site::TruckBatch batch;
    batch.resize(end - begin);
    batch.speed_mps.setConstant(speed_mps);
    batch.sprung_mass_kg.setConstant(sprung_mass_kg);
    for (Eigen::Index i = begin; i < end; ++i) {
      batch.stiffness_npm[i - begin] = k[static_cast<std::size_t>(i)];
      batch.tyre_stiffness_npm[i - begin] = kt[static_cast<std::size_t>(i)];
      batch.lateral_m[i - begin] = z[static_cast<std::size_t>(i)];
    }
    if (end > begin) site.impact_factors(batch, out.middleCols(begin, end - begin));
  });
  return out;
}

// Impact factors (sensors x (nodes x lines), node-major) of the truck at each (k[i], kt[i]) on
// every line of `lines`: the same passes as simulate() with z on those lines, with the lines
// read once for all nodes. Nodes are split over the threads in chunks (each pass is
// independent, so the chunking changes no bit).
inline Eigen::ArrayXXd simulate_on_lines(const site::Site& site, double speed_mps, double sprung_mass_kg,
                                         const std::vector<double>& k, const std::vector<double>& kt,
                                         const vehicle::LineBundle& lines,
                                         const util::ParallelRange& parallel = util::serial_range,
                                         const ForwardEdit* edit = nullptr) {
  const auto n = static_cast<Eigen::Index>(k.size());
  const Eigen::Index per_node = lines.lines();
  Eigen::ArrayXXd out(site.sensors(), n * per_node);
  constexpr Eigen::Index kNodesPerChunk = 4;
  const Eigen::Index chunks = (n + kNodesPerChunk - 1) / kNodesPerChunk;
  parallel(chunks, [&](Eigen::Index cb, Eigen::Index ce) {
    const Eigen::Index begin = cb * kNodesPerChunk, end = std::min(n, ce * kNodesPerChunk);
    if (end <= begin) return;
    if (edit != nullptr) {
      simulate_on_lines_edited(site, speed_mps, sprung_mass_kg, k, kt, lines, begin, end, *edit,
                               out.middleCols(begin * per_node, (end - begin) * per_node));
      return;
    }
    const Eigen::ArrayXd mass = Eigen::ArrayXd::Constant(end - begin, sprung_mass_kg);
    Eigen::ArrayXd kk(end - begin), kkt(end - begin);
    for (Eigen::Index i = begin; i < end; ++i) {
      kk[i - begin] = k[static_cast<std::size_t>(i)];
      kkt[i - begin] = kt[static_cast<std::size_t>(i)];
    }
    site.impact_factors_on_lines(speed_mps, mass, kk, kkt, lines, out.middleCols(begin * per_node, (end - begin) * per_node));
  });
  return out;
}

inline void check_inputs(const site::Site& site, const Eigen::Ref<const Eigen::VectorXd>& y) {
  if (y.size() != site.sensors()) {
    throw UsageError("truck table: the record has " + std::to_string(y.size()) + " impact factors but the site has " +
                     std::to_string(site.sensors()) + " sensors");
  }
}

// Sum of squared residuals of every column of `ifs` against y.
inline Eigen::ArrayXd column_ssr(const Eigen::ArrayXXd& ifs, const Eigen::Ref<const Eigen::VectorXd>& y) {
  return (ifs.colwise() - y.array()).square().colwise().sum().transpose();
}


// The best (k, k_t) fit at fixed z by Gauss–Newton with Levenberg damping in (log k, log k_t, z).
struct Point {
  double log_k, log_kt, z;
};

struct Fitter {
  const site::Site& site;
  double speed, mass;
  const Eigen::Ref<const Eigen::VectorXd>& y;
  int passes = 0;
  const ForwardEdit* edit = nullptr;  // the extension the passes run under (null: the base model)

  // Residuals at p and the Jacobian of the impact factors by forward differences.
  void residual_and_jacobian(const Point& p, Eigen::VectorXd& r, Eigen::MatrixXd& J) {
    const double h_log = 1e-4, h_z = 2e-3;
    const double lo = site.lateral_min_m(), hi = site.lateral_max_m();
    // Step z inwards at the road's edge so every evaluation stays on the surface.
    const double dz = (p.z + h_z <= hi) ? h_z : -h_z;
    std::vector<double> k{std::exp(p.log_k), std::exp(p.log_k + h_log), std::exp(p.log_k), std::exp(p.log_k)};
    std::vector<double> kt{std::exp(p.log_kt), std::exp(p.log_kt), std::exp(p.log_kt + h_log), std::exp(p.log_kt)};
    std::vector<double> z{p.z, p.z, p.z, std::clamp(p.z + dz, lo, hi)};
    const Eigen::ArrayXXd f = simulate(site, speed, mass, k, kt, z, util::serial_range, edit);
    passes += 4;
    r = y - f.col(0).matrix();
    J.resize(y.size(), 3);
    J.col(0) = ((f.col(1) - f.col(0)) / h_log).matrix();
    J.col(1) = ((f.col(2) - f.col(0)) / h_log).matrix();
    J.col(2) = ((f.col(3) - f.col(0)) / dz).matrix();
  }

  double ssr_at(const Point& p) {
    const Eigen::ArrayXXd f =
        simulate(site, speed, mass, {std::exp(p.log_k)}, {std::exp(p.log_kt)}, {p.z}, util::serial_range, edit);
    passes += 1;
    return (f.col(0).matrix() - y).squaredNorm();
  }

  // Levenberg–Marquardt from p; returns the local optimum and its SSR.
  std::pair<Point, double> optimise(Point p, double ssr) {
    return optimise(p, ssr, site.lateral_min_m(), site.lateral_max_m());
  }
  // The same with z kept in [lo, hi] (one lateral mode of several).
  std::pair<Point, double> optimise(Point p, double ssr, double lo, double hi) {
    double lambda = 1e-3;
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    for (int iter = 0; iter < 40; ++iter) {
      residual_and_jacobian(p, r, J);
      const Eigen::Matrix3d JtJ = J.transpose() * J;
      const Eigen::Vector3d g = J.transpose() * r;
      bool improved = false;
      for (int tries = 0; tries < 8 && !improved; ++tries) {
        Eigen::Matrix3d A = JtJ;
        A.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-12);
        const Eigen::Vector3d step = A.ldlt().solve(g);
        Point q{p.log_k + std::clamp(step[0], -0.5, 0.5), p.log_kt + std::clamp(step[1], -0.5, 0.5),
                std::clamp(p.z + std::clamp(step[2], -0.1, 0.1), lo, hi)};
        const double s = ssr_at(q);
        if (s < ssr) {
          const double gain = ssr - s;
          p = q;
          ssr = s;
          lambda = std::max(lambda * 0.3, 1e-9);
          improved = true;
          if (gain < 1e-12 * std::max(ssr, 1e-30)) return {p, ssr};
        } else {
          lambda *= 10.0;
        }
      }
      if (!improved) break;
    }
    return {p, ssr};
  }

  // SSR at every lateral line at fixed (k, k_t); returns the best line's position and SSR.
  std::pair<double, double> scan_lines(const std::vector<double>& ks, const std::vector<double>& kts,
                                       double* best_k, double* best_kt) {
    const road::Surface& s = site.surface();
    std::vector<double> k, kt, z;
    for (std::size_t a = 0; a < ks.size(); ++a) {
      for (Eigen::Index j = 0; j < s.lines(); ++j) {
        k.push_back(ks[a]);
        kt.push_back(kts[a]);
        z.push_back(s.lateral_m(j));
      }
    }
    const Eigen::ArrayXd ssr = column_ssr(simulate(site, speed, mass, k, kt, z, util::serial_range, edit), y);
    passes += static_cast<int>(k.size());
    Eigen::Index best = 0;
    const double best_ssr = ssr.minCoeff(&best);
    *best_k = k[static_cast<std::size_t>(best)];
    *best_kt = kt[static_cast<std::size_t>(best)];
    return {z[static_cast<std::size_t>(best)], best_ssr};
  }
};


}  // namespace ssrfleet::model::detail
