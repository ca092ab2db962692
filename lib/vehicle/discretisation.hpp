// Exact discretisation of a linear time-invariant system x' = A x + B u over a step h.
//
// With the input held between samples (zero-order hold, ZOH):
//   x_{k+1} = Phi x_k + Gamma0 u_k
// With the input linear between samples (first-order hold, FOH; exact for a profile read as a
// continuous surface, linear between samples):
//   x_{k+1} = Phi x_k + Gamma0 u_k + Gamma1 (u_{k+1} - u_k)
// where
//   Phi    = e^{A h},
//   Gamma0 = ∫_0^h e^{A s} ds B                   = h psi1(A h) B,
//   Gamma1 = ∫_0^h e^{A (h - s)} (s / h) ds B     = h psi2(A h) B,
// and psi_j(X) = sum_k X^k / (k + j)! are the phi-functions of exponential integrators.
// These are the blocks of one augmented exponential (Franklin, Powell & Workman, "Digital
// control of dynamic systems", §6.3):
//   exp([[A h, B h, 0], [0, 0, I], [0, 0, 0]]) = [[Phi, Gamma0, Gamma1], [0, I, I], [0, 0, I]].
#pragma once

#include <Eigen/Core>

namespace ssrfleet::vehicle {

template <int Inputs>
struct Discretisation {
  Eigen::Matrix4d Phi;
  Eigen::Matrix<double, 4, Inputs> Gamma0;
  Eigen::Matrix<double, 4, Inputs> Gamma1;
};

// The fast path used by the integrator (once per truck per MCMC proposal): a truncated Taylor
// series of psi2(A h) by Horner's rule on 4x4 matrices, then psi1 = I + X psi2 and
// Phi = I + X psi1, with the degree chosen from the 1-norm of the diagonally balanced A h so that
// the truncation error is below 1e-17 relative. Steps too long for that (balanced norm > 1) fall
// back to discretise_expm. Throws std::invalid_argument unless step_s is positive and finite.
template <int Inputs>
Discretisation<Inputs> discretise(const Eigen::Matrix4d& A, const Eigen::Matrix<double, 4, Inputs>& B,
                                  double step_s);

// The reference: the augmented (4 + 2 Inputs)-square matrix exponential above, by
// unsupported/Eigen/MatrixFunctions (scaling and squaring with Pade approximants). Slower.
template <int Inputs>
Discretisation<Inputs> discretise_expm(const Eigen::Matrix4d& A, const Eigen::Matrix<double, 4, Inputs>& B,
                                       double step_s);

extern template Discretisation<1> discretise<1>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 1>&, double);
extern template Discretisation<2> discretise<2>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 2>&, double);
extern template Discretisation<1> discretise_expm<1>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 1>&,
                                                     double);
extern template Discretisation<2> discretise_expm<2>(const Eigen::Matrix4d&, const Eigen::Matrix<double, 4, 2>&,
                                                     double);

}  // namespace ssrfleet::vehicle
