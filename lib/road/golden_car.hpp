// The IRI reference quarter car, the "Golden Car" (Sayers 1995, "On the calculation of
// International Roughness Index from longitudinal road profile", TRR 1501; ASTM E1926), and its
// exact discretisation. Parameters per unit sprung mass: k_t/m_s = 653, k_s/m_s = 63.3 (s^-2),
// c_s/m_s = 6.0 (s^-1), m_u/m_s = 0.15. State x = (z_s, z_s', z_u, z_u'), input r:
//   x' = A x + B r.
// (This is the road module's own small model for the IRI; the trucks' integrator lives in
// lib/vehicle.)
#pragma once

#include <Eigen/Core>

namespace ssrfleet::road {

inline constexpr double golden_car_speed_mps = 80.0 / 3.6;  // IRI is defined at 80 km/h

struct GoldenCarStateSpace {
  Eigen::Matrix4d A;
  Eigen::Vector4d B;
};
GoldenCarStateSpace golden_car_state_space();

// x_{i+1} = ST x_i + PR r_i with r held constant over each interval dt = dx / speed
// (zero-order hold): ST = exp(A dt), PR = ∫_0^dt exp(A s) ds B, both from one matrix exponential
// of the augmented matrix [[A, B], [0, 0]] (Van Loan), which needs no inverse of A.
// Sayers' IRI algorithm feeds this with the profile *slope* held constant, i.e. the profile
// linear between samples; see iri.hpp. Throws std::invalid_argument unless dx and speed are
// positive.
struct GoldenCarDiscrete {
  Eigen::Matrix4d ST;
  Eigen::Vector4d PR;
};
GoldenCarDiscrete golden_car_discrete(double dx_m, double speed_mps = golden_car_speed_mps);

}  // namespace ssrfleet::road
