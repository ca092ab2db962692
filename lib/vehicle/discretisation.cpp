// GCC 12 with -march=native (AVX-512) reports false -W(maybe-)uninitialized warnings inside Eigen's
// general matrix product kernels (avx512fintrin.h, _mm512_extractf64x4_pd), which MatrixFunctions
// instantiates. The intrinsics header comes in with the first Eigen include and the warning is
// issued at its location, so the suppression must precede every include of this file.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"

#include "vehicle/discretisation.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

#include <unsupported/Eigen/MatrixFunctions>

#include "util/check.hpp"

namespace ssrfleet::vehicle {

namespace {

// Binary exponent of a positive finite double (its bits, no library call).
inline int binary_exponent(double v) {
  return static_cast<int>((std::bit_cast<std::uint64_t>(v) >> 52) & 0x7ff) - 1023;
}

// 2^e for |e| < 1000.
inline double power_of_two(int e) {
  return std::bit_cast<double>(static_cast<std::uint64_t>(e + 1023) << 52);
}

// 1-norm of D^-1 X D after three sweeps of Osborne's diagonal balancing with powers of two (as
// LAPACK's dgebal: each state's scale chosen so its off-diagonal row and column sums match to
// within a factor of 2, exactly representable, no division). The quarter car's X = A h mixes
// displacements and velocities, so its raw norm (~12 for a truck at 5 cm and 23 m/s) wildly
// overstates how fast the Taylor series converges; the balanced norm (~0.3) is what the
// truncation bound needs. Any D gives a valid bound; balancing only makes it tight. A polynomial
// in X commutes with the similarity, so the series itself is evaluated on X; the balanced copy
// only gives the norm.
double balanced_norm1(const Eigen::Matrix4d& X) {
  std::array<double, 16> y;  // row-major |X|
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) y[static_cast<std::size_t>(4 * i + j)] = std::abs(X(i, j));
  for (int sweep = 0; sweep < 3; ++sweep) {
    for (std::size_t i = 0; i < 4; ++i) {
      double c = 0.0, r = 0.0;
      for (std::size_t j = 0; j < 4; ++j) {
        if (j == i) continue;
        c += y[4 * j + i];
        r += y[4 * i + j];
      }
      if (!(c > 0.0 && r > 0.0) || !std::isfinite(c) || !std::isfinite(r)) continue;
      const int e = (binary_exponent(r) - binary_exponent(c)) / 2;
      if (e == 0) continue;
      const double up = power_of_two(e), down = power_of_two(-e);
      for (std::size_t j = 0; j < 4; ++j) {
        y[4 * j + i] *= up;
        y[4 * i + j] *= down;
      }
    }
  }
  double norm = 0.0;
  for (std::size_t j = 0; j < 4; ++j) norm = std::max(norm, (y[j] + y[4 + j]) + (y[8 + j] + y[12 + j]));
  return norm;
}

// Smallest Taylor degree N of psi2 with theta^(N-2) 5! / (N+3)! <= 1e-17. The truncation error of
// psi2 is about theta^(N+1) / (N+3)!; an entry of psi2 B that the input reaches only through p
// couplings (p <= 3 in a 4-state chain) starts at theta^p / (p+2)!, so this bounds the error of
// every entry relative to itself, not only relative to the largest (a fine step would otherwise
// lose digits in the body's response to a ramp). The largest theta each degree allows is
// tabulated once, so choosing the degree costs a few comparisons.
int taylor_degree(double theta) {
  constexpr int kMinDegree = 3, kMaxDegree = 30;
  static const std::array<double, kMaxDegree + 1> max_theta = [] {
    std::array<double, kMaxDegree + 1> t{};
    double factorial = 720.0;  // (N+3)! at N = 3
    for (int n = kMinDegree; n <= kMaxDegree; ++n) {
      if (n > kMinDegree) factorial *= static_cast<double>(n + 3);
      t[static_cast<std::size_t>(n)] = std::pow(1e-17 * factorial / 120.0, 1.0 / static_cast<double>(n - 2));
    }
    return t;
  }();
  int n = kMinDegree;
  while (n < kMaxDegree && theta > max_theta[static_cast<std::size_t>(n)]) ++n;
  return n;
}

constexpr double kMaxBalancedNorm = 1.0;

// 1/n! for n = 0..33.
constexpr std::array<double, 34> kInverseFactorial = [] {
  std::array<double, 34> f{};
  f[0] = 1.0;
  for (std::size_t n = 1; n < f.size(); ++n) f[n] = f[n - 1] / static_cast<double>(n);
  return f;
}();

// 4x4 products on plain row-major arrays, in a fixed order of operations (no FMA contraction,
// unlike Eigen's packet kernels on FMA hardware), so portable and native builds give the same
// bits; GCC vectorises the loop over j.
using M4 = std::array<double, 16>;

inline M4 mul(const M4& a, const M4& b) {
  M4 c;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      c[4 * i + j] = (a[4 * i + 0] * b[0 + j] + a[4 * i + 1] * b[4 + j]) +
                     (a[4 * i + 2] * b[8 + j] + a[4 * i + 3] * b[12 + j]);
  return c;
}

inline void add_identity(M4& a, double s) {
  for (int i = 0; i < 4; ++i) a[5 * i] += s;
}

}  // namespace

template <int Inputs>
Discretisation<Inputs> discretise(const Eigen::Matrix4d& A, const Eigen::Matrix<double, 4, Inputs>& B,
                                  double step_s) {
  check_positive("discretise", "step_s", step_s);
  const Eigen::Matrix4d Xe = A * step_s;
  const double theta = balanced_norm1(Xe);
  if (!(theta <= kMaxBalancedNorm)) return discretise_expm<Inputs>(A, B, step_s);
  const int n = taylor_degree(theta);

  M4 X;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) X[static_cast<std::size_t>(4 * i + j)] = Xe(i, j);
  // psi2 = sum_{k=0}^{n} X^k / (k+2)! by Paterson-Stockmeyer with X^4: groups
  // G_m = sum_{i<4} X^i / (4m+i+2)!, psi2 = G_0 + X^4 (G_1 + X^4 (G_2 + ...)): 3 products for
  // the powers and ceil((n+1)/4) - 1 more, instead of n for plain Horner.
  const M4 X2 = mul(X, X);
  const M4 X3 = mul(X2, X);
  const M4 X4 = mul(X2, X2);
  const auto group = [&](int m) {
    M4 g;
    const std::size_t k = static_cast<std::size_t>(4 * m);
    const auto coefficient = [&](std::size_t i) {
      return k + i <= static_cast<std::size_t>(n) ? kInverseFactorial[k + i + 2] : 0.0;
    };
    const double c0 = coefficient(0), c1 = coefficient(1), c2 = coefficient(2), c3 = coefficient(3);
    for (std::size_t e = 0; e < 16; ++e) g[e] = (c1 * X[e] + c2 * X2[e]) + c3 * X3[e];
    add_identity(g, c0);
    return g;
  };
  const int groups = (n + 4) / 4;  // ceil((n+1)/4)
  M4 psi2 = group(groups - 1);
  for (int m = groups - 2; m >= 0; --m) {
    const M4 t = mul(X4, psi2);
    const M4 g = group(m);
    for (std::size_t e = 0; e < 16; ++e) psi2[e] = t[e] + g[e];
  }
  M4 psi1 = mul(X, psi2);
  add_identity(psi1, 1.0);
  M4 phi = mul(X, psi1);
  add_identity(phi, 1.0);

  Discretisation<Inputs> d;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) d.Phi(i, j) = phi[static_cast<std::size_t>(4 * i + j)];
    for (int u = 0; u < Inputs; ++u) {
      double g0 = 0.0, g1 = 0.0;
      for (int j = 0; j < 4; ++j) {
        g0 += psi1[static_cast<std::size_t>(4 * i + j)] * B(j, u);
        g1 += psi2[static_cast<std::size_t>(4 * i + j)] * B(j, u);
      }
      d.Gamma0(i, u) = step_s * g0;
      d.Gamma1(i, u) = step_s * g1;
    }
  }
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
template Discretisation<1> discretise_expm<1>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 1>&,
                                              double);
template Discretisation<2> discretise_expm<2>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 2>&,
                                              double);

}  // namespace ssrfleet::vehicle
