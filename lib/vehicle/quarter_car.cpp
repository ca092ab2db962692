// The quarter-car equations (docs/model.md; the paper's eqs. (1)-(4), linear tyre, optional
// tyre damping) written as a continuous state space.
#include "vehicle/quarter_car.hpp"

#include <stdexcept>
#include <string>

#include "util/check.hpp"

namespace ssrfleet::vehicle {

namespace {
// Every array of a batch must have the same length, or indexing one truck reads past an end.
void check_batch_index(const QuarterCarBatch& b, Eigen::Index i, const char* fn) {
  const Eigen::Index n = b.size();
  if (b.unsprung_mass_kg.size() != n || b.suspension_stiffness_npm.size() != n ||
      b.suspension_damping_nspm.size() != n || b.tyre_stiffness_npm.size() != n ||
      b.tyre_damping_nspm.size() != n)
    throw std::invalid_argument(std::string(fn) +
                                ": the batch's arrays differ in length (sprung_mass_kg has " +
                                std::to_string(n) + ")");
  if (i < 0 || i >= n)
    throw std::out_of_range(std::string(fn) + ": index " + std::to_string(i) + " outside [0, " +
                            std::to_string(n) + ")");
}
}  // namespace

void validate(const QuarterCar& car) {
  constexpr std::string_view fn = "QuarterCar";
  check_positive(fn, "sprung_mass_kg", car.sprung_mass_kg);
  check_positive(fn, "unsprung_mass_kg", car.unsprung_mass_kg);
  check_positive(fn, "suspension_stiffness_npm", car.suspension_stiffness_npm);
  check_nonnegative(fn, "suspension_damping_nspm", car.suspension_damping_nspm);
  check_positive(fn, "tyre_stiffness_npm", car.tyre_stiffness_npm);
  check_nonnegative(fn, "tyre_damping_nspm", car.tyre_damping_nspm);
}

StateSpace state_space(const QuarterCar& car) {
  const double m1 = car.unsprung_mass_kg;
  const double m2 = car.sprung_mass_kg;
  const double k = car.suspension_stiffness_npm;
  const double cb = car.suspension_damping_nspm;
  const double kt = car.tyre_stiffness_npm;
  const double ct = car.tyre_damping_nspm;
  StateSpace ss;
  // x = (y1, y1', y2, y2'), u = (r, r').
  // m1 y1'' = k (y2 - y1) + c_b (y2' - y1') - k_t (y1 - r) - c_t (y1' - r')
  // m2 y2'' = -k (y2 - y1) - c_b (y2' - y1')
  ss.A << 0.0, 1.0, 0.0, 0.0,                            //
      -(k + kt) / m1, -(cb + ct) / m1, k / m1, cb / m1,  //
      0.0, 0.0, 0.0, 1.0,                                //
      k / m2, cb / m2, -k / m2, -cb / m2;
  ss.B << 0.0, 0.0,      //
      kt / m1, ct / m1,  //
      0.0, 0.0,          //
      0.0, 0.0;
  return ss;
}

void QuarterCarBatch::assign(Eigen::Index n, const QuarterCar& car) {
  sprung_mass_kg.setConstant(n, car.sprung_mass_kg);
  unsprung_mass_kg.setConstant(n, car.unsprung_mass_kg);
  suspension_stiffness_npm.setConstant(n, car.suspension_stiffness_npm);
  suspension_damping_nspm.setConstant(n, car.suspension_damping_nspm);
  tyre_stiffness_npm.setConstant(n, car.tyre_stiffness_npm);
  tyre_damping_nspm.setConstant(n, car.tyre_damping_nspm);
}

QuarterCar QuarterCarBatch::car(Eigen::Index i) const {
  check_batch_index(*this, i, "QuarterCarBatch::car()");
  QuarterCar c;
  c.sprung_mass_kg = sprung_mass_kg[i];
  c.unsprung_mass_kg = unsprung_mass_kg[i];
  c.suspension_stiffness_npm = suspension_stiffness_npm[i];
  c.suspension_damping_nspm = suspension_damping_nspm[i];
  c.tyre_stiffness_npm = tyre_stiffness_npm[i];
  c.tyre_damping_nspm = tyre_damping_nspm[i];
  return c;
}

void QuarterCarBatch::set_car(Eigen::Index i, const QuarterCar& car) {
  check_batch_index(*this, i, "QuarterCarBatch::set_car()");
  sprung_mass_kg[i] = car.sprung_mass_kg;
  unsprung_mass_kg[i] = car.unsprung_mass_kg;
  suspension_stiffness_npm[i] = car.suspension_stiffness_npm;
  suspension_damping_nspm[i] = car.suspension_damping_nspm;
  tyre_stiffness_npm[i] = car.tyre_stiffness_npm;
  tyre_damping_nspm[i] = car.tyre_damping_nspm;
}

}  // namespace ssrfleet::vehicle
