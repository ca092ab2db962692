#include "road/iri.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "road/golden_car.hpp"
#include "util/check.hpp"

namespace ssrfleet::road {

namespace {
constexpr double kSmoothingBase_m = 0.25;
constexpr double kInitialLength_m = 11.0;
}  // namespace

Eigen::Index iri_smoothing_points(double dx_m) {
  check_positive("iri_m_per_km", "dx_m", dx_m);
  return std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::llround(kSmoothingBase_m / dx_m)));
}

double iri_m_per_km(const Eigen::ArrayXd& profile_m, double dx_m) {
  const Eigen::Index k = iri_smoothing_points(dx_m);
  const Eigen::Index n = profile_m.size();
  if (n < k + 1) {
    throw std::invalid_argument("iri_m_per_km: profile of " + std::to_string(n) +
                                " samples is shorter than the 0.25 m smoothing base plus one sample");
  }
  const GoldenCarDiscrete d = golden_car_discrete(dx_m, golden_car_speed_mps);

  const Eigen::Index i11 = std::min<Eigen::Index>(n - 1, std::llround(kInitialLength_m / dx_m));
  const double initial_slope = (profile_m(i11) - profile_m(0)) / (static_cast<double>(i11) * dx_m);
  Eigen::Vector4d z(initial_slope, 0.0, initial_slope, 0.0);

  const double base_m = static_cast<double>(k) * dx_m;
  const Eigen::Index steps = n - k;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < steps; ++i) {
    const double slope = (profile_m(i + k) - profile_m(i)) / base_m;
    z = d.ST * z + d.PR * slope;
    sum += std::abs(z(0) - z(2));
  }
  return 1000.0 * sum / static_cast<double>(steps);
}

}  // namespace ssrfleet::road
