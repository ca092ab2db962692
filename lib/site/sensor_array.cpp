#include "site/sensor_array.hpp"

#include <cmath>
#include <string>

#include "util/errors.hpp"

namespace ssrfleet::site {

void SensorArray::validate() const {
  if (count < 1) throw UsageError("sensors: count is " + std::to_string(count) + ", but must be at least 1");
  if (count > kMaxSensors) {
    throw UsageError("sensors: count is " + std::to_string(count) + ", but must be at most " + std::to_string(kMaxSensors));
  }
  if (!std::isfinite(first_m) || first_m < 0.0) {
    throw UsageError("sensors: first position is " + std::to_string(first_m) + " m, but must be >= 0");
  }
  if (count > 1 && !(std::isfinite(spacing_m) && spacing_m > 0.0)) {
    throw UsageError("sensors: spacing is " + std::to_string(spacing_m) + " m, but must be positive");
  }
}

std::vector<double> SensorArray::positions_m() const {
  validate();
  std::vector<double> p(static_cast<std::size_t>(count));
  // first + m * spacing, not a running sum: 76.0 + 15 * 1.5 must be exactly 98.5.
  for (int m = 0; m < count; ++m) p[static_cast<std::size_t>(m)] = first_m + m * spacing_m;
  return p;
}

}  // namespace ssrfleet::site
