// The batched pass kernel of PassIntegrator (pass_integrator.cpp): per-truck coefficients of the
// exact first-order-hold discretisation, the expressions shared by the single and the batched
// pass (so both give the same bits), and the block state that advances BS trucks in lock-step,
// vectorised across trucks. The derivation is in pass_integrator.cpp's header. Internal to
// vehicle/: not part of the integrator's interface.
#pragma once

#include <algorithm>
#include <array>
#include <cstring>
#include <vector>

#include <Eigen/Core>

#include "vehicle/discretisation.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::vehicle::pass_kernel {

// Everything a truck needs per step, computed once per pass (once per MCMC proposal).
struct TruckCoefficients {
  std::array<double, 16> phi;  // row-major Phi
  std::array<double, 4> gamma;
  std::array<double, 4> q;
  double a = 0.0;    // k_t / W
  double b = 0.0;    // c_t / W
  double c_r = 0.0;  // a (1 - q0) - b q1: IF - 1 = c_r r + e (r - r_before) - a z0 - b z1
  double e = 0.0;    // b / h
  double step_s = 0.0;
};

// Rows y1, y1' of the state at an output a fraction f of a step beyond sample j:
// (y1, y1') = phi z_j + alpha r_j + beta r_{j+1}.
struct PartialCoefficients {
  std::array<double, 8> phi;  // rows 0 and 1 of Phi(f h), row-major
  std::array<double, 2> alpha;
  std::array<double, 2> beta;
};

inline TruckCoefficients truck_coefficients(const QuarterCar& car, double speed_mps, double dx_m,
                                     const std::vector<double>& fractions, PartialCoefficients* partial) {
  const StateSpace ss = state_space(car);
  const double h = dx_m / speed_mps;
  const Discretisation<2> d = discretise<2>(ss.A, ss.B, h);
  const Eigen::Vector4d p = d.Gamma0.col(0) - d.Gamma0.col(1) / h - d.Gamma1.col(0);
  const Eigen::Vector4d q = d.Gamma0.col(1) / h + d.Gamma1.col(0);
  const Eigen::Vector4d gamma = d.Phi * q + p;
  const double w = car.static_weight_n();
  TruckCoefficients c;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) c.phi[static_cast<std::size_t>(4 * i + j)] = d.Phi(i, j);
    c.gamma[static_cast<std::size_t>(i)] = gamma[i];
    c.q[static_cast<std::size_t>(i)] = q[i];
  }
  c.a = car.tyre_stiffness_npm / w;
  c.b = car.tyre_damping_nspm / w;
  c.c_r = c.a * (1.0 - q[0]) - c.b * q[1];
  c.e = c.b / h;
  c.step_s = h;
  for (std::size_t s = 0; s < fractions.size(); ++s) {
    const double f = fractions[s];
    const Discretisation<2> df = discretise<2>(ss.A, ss.B, f * h);
    const Eigen::Vector4d alpha = df.Phi * q + df.Gamma0.col(0) - df.Gamma0.col(1) / h - f * df.Gamma1.col(0);
    const Eigen::Vector4d beta = df.Gamma0.col(1) / h + f * df.Gamma1.col(0);
    PartialCoefficients& pc = partial[s];
    for (int i = 0; i < 2; ++i) {
      for (int j = 0; j < 4; ++j) pc.phi[static_cast<std::size_t>(4 * i + j)] = df.Phi(i, j);
      pc.alpha[static_cast<std::size_t>(i)] = alpha[i];
      pc.beta[static_cast<std::size_t>(i)] = beta[i];
    }
  }
  return c;
}

// The expressions below are shared by run() and run_batch() so that both give the same bits.
inline double affine4(double p0, double p1, double p2, double p3, double z0, double z1, double z2, double z3,
                      double g, double r) {
  return ((p0 * z0 + p1 * z1) + (p2 * z2 + p3 * z3)) + g * r;
}

inline double path_height(const double* la, const double* lb, double wa, double wb, Eigen::Index j) {
  return wa * la[j] + wb * lb[j];
}

// IF - 1 at a sample, from z there, the height there and the height one sample before.
template <bool Damped>
inline double grid_if_minus_one(double c_r, double e, double a, double b, double r, double r_before,
                                double z0, double z1) {
  if constexpr (Damped) {
    return ((c_r * r + e * (r - r_before)) - a * z0) - b * z1;
  } else {
    (void)e;
    (void)b;
    (void)r_before;
    (void)z1;
    return c_r * r - a * z0;
  }
}

// IF - 1 a fraction f of a step beyond sample j.
inline double partial_if_minus_one(const TruckCoefficients& c, const PartialCoefficients& pc, double f,
                                   const double* z, double r_j, double r_next) {
  const double y1 =
      affine4(pc.phi[0], pc.phi[1], pc.phi[2], pc.phi[3], z[0], z[1], z[2], z[3], pc.alpha[0], r_j) +
      pc.beta[0] * r_next;
  const double y1d =
      affine4(pc.phi[4], pc.phi[5], pc.phi[6], pc.phi[7], z[0], z[1], z[2], z[3], pc.alpha[1], r_j) +
      pc.beta[1] * r_next;
  const double dr = r_next - r_j;
  const double r = r_j + f * dr;
  const double slope = dr / c.step_s;
  return c.a * (r - y1) + c.b * (slope - y1d);
}

inline void initial_z(const TruckCoefficients& c, double r0, double* z) {
  // Static equilibrium on the first sample: x = (r0, 0, r0, 0), z = x - q r0.
  z[0] = r0 - c.q[0] * r0;
  z[1] = -(c.q[1] * r0);
  z[2] = r0 - c.q[2] * r0;
  z[3] = -(c.q[3] * r0);
}

// Batched kernel state for one block of BS trucks, all in L1: coefficient and state arrays of
// BS doubles each (one per truck), and a chunk of wheel-path heights transposed to
// [sample][truck] so the inner loop over trucks reads contiguous memory.
constexpr int kChunk = 64;

template <int BS>
struct alignas(64) BlockState {
  double phi[16][BS];
  double gamma[4][BS];
  double a[BS], b[BS], c_r[BS], e[BS];
  double z[4][BS];
  double min_m[BS];
  double wa[BS], wb[BS];
  const double* la[BS];
  const double* lb[BS];
  double r[kChunk + 1][BS];
};

// Fills s.r rows 0..n with heights at samples k..k+n: a transpose from per-truck lines to
// [sample][truck]. Done element by element it costs as much as a third of the steps themselves,
// so on GCC it computes W samples of W trucks as W short vectors along the lines and transposes
// them in registers (W = 4 with AVX, 2 with SSE2); the heights are the same expression, so the
// bits are those of path_height().
template <int BS>
inline void load_heights_scalar(BlockState<BS>& s, Eigen::Index k, int first, int n) {
  for (int t = 0; t < BS; ++t) {
    const double* la = s.la[t];
    const double* lb = s.lb[t];
    const double wa = s.wa[t], wb = s.wb[t];
    for (int i = first; i <= n; ++i) s.r[i][t] = path_height(la, lb, wa, wb, k + i);
  }
}

#if defined(__GNUC__) && !defined(__clang__)
#if defined(__AVX__)
constexpr int kTransposeWidth = 4;
#else
constexpr int kTransposeWidth = 2;
#endif
using VecW = double __attribute__((vector_size(8 * kTransposeWidth)));
using IdxW = long long __attribute__((vector_size(8 * kTransposeWidth)));

inline VecW load_vec(const double* p) {
  VecW v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <int BS>
inline void load_heights(BlockState<BS>& s, Eigen::Index k, int n) {
  constexpr int W = kTransposeWidth;
  static_assert(BS % W == 0, "block must be a multiple of the transpose width");
  const int full = (n + 1) / W * W;
  for (int t = 0; t < BS; t += W) {
    VecW rows[W];
    for (int i = 0; i < full; i += W) {
      for (int u = 0; u < W; ++u)
        rows[u] = s.wa[t + u] * load_vec(s.la[t + u] + k + i) + s.wb[t + u] * load_vec(s.lb[t + u] + k + i);
#if defined(__AVX__)
      const VecW t0 = __builtin_shuffle(rows[0], rows[1], IdxW{0, 4, 2, 6});
      const VecW t1 = __builtin_shuffle(rows[0], rows[1], IdxW{1, 5, 3, 7});
      const VecW t2 = __builtin_shuffle(rows[2], rows[3], IdxW{0, 4, 2, 6});
      const VecW t3 = __builtin_shuffle(rows[2], rows[3], IdxW{1, 5, 3, 7});
      const VecW c0 = __builtin_shuffle(t0, t2, IdxW{0, 1, 4, 5});
      const VecW c1 = __builtin_shuffle(t1, t3, IdxW{0, 1, 4, 5});
      const VecW c2 = __builtin_shuffle(t0, t2, IdxW{2, 3, 6, 7});
      const VecW c3 = __builtin_shuffle(t1, t3, IdxW{2, 3, 6, 7});
      std::memcpy(&s.r[i][t], &c0, sizeof c0);
      std::memcpy(&s.r[i + 1][t], &c1, sizeof c1);
      std::memcpy(&s.r[i + 2][t], &c2, sizeof c2);
      std::memcpy(&s.r[i + 3][t], &c3, sizeof c3);
#else
      const VecW c0 = __builtin_shuffle(rows[0], rows[1], IdxW{0, 2});
      const VecW c1 = __builtin_shuffle(rows[0], rows[1], IdxW{1, 3});
      std::memcpy(&s.r[i][t], &c0, sizeof c0);
      std::memcpy(&s.r[i + 1][t], &c1, sizeof c1);
#endif
    }
  }
  load_heights_scalar(s, k, full, n);
}
#else
template <int BS>
inline void load_heights(BlockState<BS>& s, Eigen::Index k, int n) {
  load_heights_scalar(s, k, 0, n);
}
#endif

// n steps from the sample in row 0 of s.r; the inner loop over trucks vectorises.
template <int BS, bool Damped>
inline void advance(BlockState<BS>& s, int n) {
  for (int i = 0; i < n; ++i) {
    const double* __restrict r0 = s.r[i];
    const double* __restrict r1 = s.r[i + 1];
#pragma GCC ivdep
    for (int t = 0; t < BS; ++t) {
      const double z0 = s.z[0][t], z1 = s.z[1][t], z2 = s.z[2][t], z3 = s.z[3][t];
      const double rt = r0[t];
      const double n0 =
          affine4(s.phi[0][t], s.phi[1][t], s.phi[2][t], s.phi[3][t], z0, z1, z2, z3, s.gamma[0][t], rt);
      const double n1 =
          affine4(s.phi[4][t], s.phi[5][t], s.phi[6][t], s.phi[7][t], z0, z1, z2, z3, s.gamma[1][t], rt);
      const double n2 =
          affine4(s.phi[8][t], s.phi[9][t], s.phi[10][t], s.phi[11][t], z0, z1, z2, z3, s.gamma[2][t], rt);
      const double n3 =
          affine4(s.phi[12][t], s.phi[13][t], s.phi[14][t], s.phi[15][t], z0, z1, z2, z3, s.gamma[3][t], rt);
      s.z[0][t] = n0;
      s.z[1][t] = n1;
      s.z[2][t] = n2;
      s.z[3][t] = n3;
      const double m = grid_if_minus_one<Damped>(s.c_r[t], s.e[t], s.a[t], s.b[t], r1[t], rt, n0, n1);
      s.min_m[t] = m < s.min_m[t] ? m : s.min_m[t];
    }
  }
}

}  // namespace ssrfleet::vehicle::pass_kernel
