#include "vehicle/frequency_response.hpp"

#include <numbers>

#include <Eigen/Dense>

#include "util/check.hpp"

namespace ssrfleet::vehicle {

std::complex<double> impact_factor_response(const QuarterCar& car, double angular_frequency_rps) {
  validate(car);
  check_nonnegative("impact_factor_response", "angular_frequency_rps", angular_frequency_rps);
  const StateSpace ss = state_space(car);
  const std::complex<double> iw(0.0, angular_frequency_rps);
  const Eigen::Matrix4cd M = iw * Eigen::Matrix4cd::Identity() - ss.A.cast<std::complex<double>>();
  const Eigen::Vector2cd U(1.0, iw);
  const Eigen::Vector4cd X = M.partialPivLu().solve(ss.B.cast<std::complex<double>>() * U);
  return (car.tyre_stiffness_npm * (1.0 - X[0]) + car.tyre_damping_nspm * (iw - X[1])) / car.static_weight_n();
}

std::complex<double> impact_factor_response_wavelength(const QuarterCar& car, double speed_mps,
                                                       double wavelength_m) {
  check_positive("impact_factor_response_wavelength", "speed_mps", speed_mps);
  check_positive("impact_factor_response_wavelength", "wavelength_m", wavelength_m);
  return impact_factor_response(car, 2.0 * std::numbers::pi * speed_mps / wavelength_m);
}

}  // namespace ssrfleet::vehicle
