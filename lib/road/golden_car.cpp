#include "road/golden_car.hpp"

#include <unsupported/Eigen/MatrixFunctions>

#include "util/check.hpp"

namespace ssrfleet::road {

GoldenCarStateSpace golden_car_state_space() {
  constexpr double k1 = 653.0;  // k_t / m_s
  constexpr double k2 = 63.3;   // k_s / m_s
  constexpr double c = 6.0;     // c_s / m_s
  constexpr double u = 0.15;    // m_u / m_s
  GoldenCarStateSpace ss;
  ss.A << 0.0, 1.0, 0.0, 0.0,
          -k2, -c, k2, c,
          0.0, 0.0, 0.0, 1.0,
          k2 / u, c / u, -(k1 + k2) / u, -c / u;
  ss.B << 0.0, 0.0, 0.0, k1 / u;
  return ss;
}

GoldenCarDiscrete golden_car_discrete(double dx_m, double speed_mps) {
  check_positive("golden_car_discrete", "dx_m", dx_m);
  check_positive("golden_car_discrete", "speed_mps", speed_mps);
  const GoldenCarStateSpace ss = golden_car_state_space();
  const double dt_s = dx_m / speed_mps;
  Eigen::Matrix<double, 5, 5> augmented = Eigen::Matrix<double, 5, 5>::Zero();
  augmented.topLeftCorner<4, 4>() = ss.A * dt_s;
  augmented.topRightCorner<4, 1>() = ss.B * dt_s;
  const Eigen::Matrix<double, 5, 5> e = augmented.exp();
  return {e.topLeftCorner<4, 4>(), e.topRightCorner<4, 1>()};
}

}  // namespace ssrfleet::road
