// GCC 12 with -march=native (AVX-512) reports false -W(maybe-)uninitialized warnings inside Eigen's
// general matrix product kernels (avx512fintrin.h, _mm512_extractf64x4_pd), which MatrixFunctions
// instantiates. The intrinsics header comes in with the first Eigen include and the warning is
// issued at its location, so the suppression must precede every include of this file.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"

#include "vehicle/discretisation.hpp"

#include <array>
#include <cmath>

#include <unsupported/Eigen/MatrixFunctions>

#include "util/check.hpp"

namespace ssrfleet::vehicle {

namespace {

// 1-norm of D^-1 X D after a few sweeps of Osborne's diagonal balancing (powers of two, as in
// LAPACK's dgebal). The quarter car's X = A h mixes displacements and velocities, so its raw norm
// (~12 for a truck at 5 cm / 23 m/s) wildly overstates how fast the Taylor series converges; the
// balanced norm (~0.3) is what the truncation bound needs. A polynomial in X commutes with the
// similarity, so the series is evaluated on X itself.
double balanced_norm1(const Eigen::Matrix4d& X) {
  std::array<double, 4> d{1.0, 1.0, 1.0, 1.0};
  for (int sweep = 0; sweep < 4; ++sweep) {
    bool changed = false;
    for (int i = 0; i < 4; ++i) {
      double c = 0.0, r = 0.0;
      for (int j = 0; j < 4; ++j) {
        if (j == i) continue;
        c += std::abs(X(j, i)) * d[i] / d[j];
        r += std::abs(X(i, j)) * d[j] / d[i];
      }
      if (c == 0.0 || r == 0.0) continue;
      double f = 1.0;
      const double s = c + r;
      while (c < r / 2.0) { c *= 2.0; r /= 2.0; f *= 2.0; }
      while (c >= r * 2.0) { c /= 2.0; r *= 2.0; f /= 2.0; }
      if ((c + r) < 0.95 * s) { d[i] *= f; changed = true; }
    }
    if (!changed) break;
  }
  double norm = 0.0;
  for (int j = 0; j < 4; ++j) {
    double col = 0.0;
    for (int i = 0; i < 4; ++i) col += std::abs(X(i, j)) * d[j] / d[i];
    norm = std::max(norm, col);
  }
  return norm;
}

// Smallest Taylor degree N of psi2 with theta^(N-2) 5! / (N+3)! <= 1e-17. The truncation error of
// psi2 is about theta^(N+1) / (N+3)!; an entry of psi2 B that the input reaches only through p
// couplings (p <= 3 in a 4-state chain) starts at theta^p / (p+2)!, so this bounds the error of
// every entry relative to itself, not only relative to the largest (a fine step would otherwise
// lose digits in the body's response to a ramp).
int taylor_degree(double theta) {
  int n = 3;
  double term = theta * 120.0 / 720.0;  // theta^(N-2) 5! / (N+3)! at N = 3
  while (term > 1e-17 && n < 30) {
    ++n;
    term *= theta / static_cast<double>(n + 3);
  }
  return n;
}

constexpr double kMaxBalancedNorm = 1.0;

}  // namespace

template <int Inputs>
Discretisation<Inputs> discretise(const Eigen::Matrix4d& A, const Eigen::Matrix<double, 4, Inputs>& B,
                                  double step_s) {
  check_positive("discretise", "step_s", step_s);
  const Eigen::Matrix4d X = A * step_s;
  const double theta = balanced_norm1(X);
  if (!(theta <= kMaxBalancedNorm)) return discretise_expm<Inputs>(A, B, step_s);
  const int n = taylor_degree(theta);

  // Horner: psi2 = sum_{k=0}^{n} X^k / (k+2)!.
  std::array<double, 34> inv_fact{};
  inv_fact[0] = 1.0;
  for (int k = 1; k < 34; ++k) inv_fact[k] = inv_fact[k - 1] / static_cast<double>(k);
  Eigen::Matrix4d psi2 = Eigen::Matrix4d::Identity() * inv_fact[n + 2];
  for (int k = n - 1; k >= 0; --k) {
    psi2 = (X * psi2).eval();
    psi2.diagonal().array() += inv_fact[k + 2];
  }
  Eigen::Matrix4d psi1 = X * psi2;
  psi1.diagonal().array() += 1.0;
  Discretisation<Inputs> d;
  d.Phi = X * psi1;
  d.Phi.diagonal().array() += 1.0;
  d.Gamma0 = step_s * (psi1 * B);
  d.Gamma1 = step_s * (psi2 * B);
  return d;
}

template <int Inputs>
Discretisation<Inputs> discretise_expm(const Eigen::Matrix4d& A, const Eigen::Matrix<double, 4, Inputs>& B,
                                       double step_s) {
  check_positive("discretise_expm", "step_s", step_s);
  constexpr int N = 4 + 2 * Inputs;
  Eigen::Matrix<double, N, N> M = Eigen::Matrix<double, N, N>::Zero();
  M.template topLeftCorner<4, 4>() = A * step_s;
  M.template block<4, Inputs>(0, 4) = B * step_s;
  M.template block<Inputs, Inputs>(4, 4 + Inputs).setIdentity();
  const Eigen::Matrix<double, N, N> E = M.exp();
  Discretisation<Inputs> d;
  d.Phi = E.template topLeftCorner<4, 4>();
  d.Gamma0 = E.template block<4, Inputs>(0, 4);
  d.Gamma1 = E.template block<4, Inputs>(0, 4 + Inputs);
  return d;
}

template Discretisation<1> discretise<1>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 1>&, double);
template Discretisation<2> discretise<2>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 2>&, double);
template Discretisation<1> discretise_expm<1>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 1>&, double);
template Discretisation<2> discretise_expm<2>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 2>&, double);

}  // namespace ssrfleet::vehicle
