#include "road/wheel_path.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace ssrfleet::road {

LateralBracket bracket(const Surface& surface, double z_m) {
  if (surface.lines() < 1 || surface.samples() < 1) throw std::out_of_range("wheel_path: the surface is empty");
  if (!(std::isfinite(z_m) && z_m >= surface.y0_m && z_m <= surface.y_max_m())) {
    std::ostringstream os;
    os.precision(17);
    os << "wheel_path: lateral position z = " << z_m << " m is outside the road surface '" << surface.name
       << "', which spans y = " << surface.y0_m << " .. " << surface.y_max_m() << " m";
    throw std::out_of_range(os.str());
  }
  if (surface.lines() == 1) return {0, 0, 0.0};
  double t = (z_m - surface.y0_m) / surface.dy_m;
  if (std::abs(t - std::round(t)) < 1e-9) t = std::round(t);
  const auto last = surface.lines() - 1;
  const Eigen::Index a = std::min(static_cast<Eigen::Index>(std::floor(t)), last);
  if (a == last) return {last, last, 0.0};  // exactly on the last line
  return {a, a + 1, t - static_cast<double>(a)};
}

Eigen::ArrayXd wheel_path(const Surface& surface, double z_m) {
  const LateralBracket b = bracket(surface, z_m);
  if (b.weight_b == 0.0) return surface.height_m.col(b.line_a);
  return (1.0 - b.weight_b) * surface.height_m.col(b.line_a) + b.weight_b * surface.height_m.col(b.line_b);
}

}  // namespace ssrfleet::road
