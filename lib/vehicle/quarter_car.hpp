// The quarter-car (one axle) of docs/model.md and the paper's equations (1)-(4), with the tyre
// linear (the "^3" in the seed's eq. (3) is a text-extraction artefact) and an optional tyre
// damping c_t (0 in the paper). Displacements y1 (axle), y2 (body) from static equilibrium,
// upward positive:
//   m2 y2'' = -k (y2 - y1) - c_b (y2' - y1')
//   m1 y1'' =  k (y2 - y1) + c_b (y2' - y1') - k_t (y1 - r) - c_t (y1' - r')
//   R = (m1 + m2) g + k_t (r - y1) + c_t (r' - y1'),   IF = R / ((m1 + m2) g)
#pragma once

#include <Eigen/Core>

namespace ssrfleet::vehicle {

inline constexpr double gravity_mps2 = 9.81;

struct QuarterCar {
  double sprung_mass_kg = 4450.0;             // m2
  double unsprung_mass_kg = 420.0;            // m1
  double suspension_stiffness_npm = 500e3;    // k
  double suspension_damping_nspm = 20e3;      // c_b
  double tyre_stiffness_npm = 1950e3;         // k_t
  double tyre_damping_nspm = 0.0;             // c_t

  double static_weight_n() const { return (sprung_mass_kg + unsprung_mass_kg) * gravity_mps2; }
  bool operator==(const QuarterCar&) const = default;
};

// Throws std::invalid_argument naming the offending field unless every mass and stiffness is
// positive and every damping non-negative.
void validate(const QuarterCar& car);

// Continuous state space with state x = (y1, y1', y2, y2') and input u = (r, r'):
//   x' = A x + B u.
struct StateSpace {
  Eigen::Matrix4d A;
  Eigen::Matrix<double, 4, 2> B;
};
StateSpace state_space(const QuarterCar& car);

// Many quarter cars side by side (structure of arrays) for the batched integrator.
struct QuarterCarBatch {
  Eigen::ArrayXd sprung_mass_kg;
  Eigen::ArrayXd unsprung_mass_kg;
  Eigen::ArrayXd suspension_stiffness_npm;
  Eigen::ArrayXd suspension_damping_nspm;
  Eigen::ArrayXd tyre_stiffness_npm;
  Eigen::ArrayXd tyre_damping_nspm;

  Eigen::Index size() const { return sprung_mass_kg.size(); }
  // Sizes every array to n and fills it with the values of `car`.
  void assign(Eigen::Index n, const QuarterCar& car);
  QuarterCar car(Eigen::Index i) const;
  void set_car(Eigen::Index i, const QuarterCar& car);
};

}  // namespace ssrfleet::vehicle
