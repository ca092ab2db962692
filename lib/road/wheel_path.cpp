#include "road/wheel_path.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "road/missing_cells.hpp"
#include "util/errors.hpp"

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

MissingCells missing_on_path(const Surface& surface, double z_m) {
  const LateralBracket b = bracket(surface, z_m);
  const Eigen::Index last = b.weight_b == 0.0 ? b.line_a : b.line_b;
  return find_missing(surface, 0, surface.samples(), b.line_a, last + 1);
}

Eigen::ArrayXd complete_wheel_path(const Surface& surface, double z_m) {
  const MissingCells missing = missing_on_path(surface, z_m);
  if (missing.count > 0) {
    std::ostringstream where;
    where << "wheel path z = " << z_m << " m";
    throw DataError(surface.name, 0, where.str(),
                    "crosses " + describe(missing, surface) +
                        ": a wheel path must lie on measured road (choose positions clear of the holes)");
  }
  return wheel_path(surface, z_m);
}

LongitudinalProfiles wheel_path_profiles(const Surface& surface, const std::vector<double>& zs_m) {
  LongitudinalProfiles p;
  p.name = surface.name;
  p.dx_m = surface.dx_m;
  p.height_m.resize(surface.samples(), static_cast<Eigen::Index>(zs_m.size()));
  for (std::size_t k = 0; k < zs_m.size(); ++k) {
    p.height_m.col(static_cast<Eigen::Index>(k)) = complete_wheel_path(surface, zs_m[k]);
    std::ostringstream label;
    label.precision(4);
    label << "z=" << zs_m[k] << "m";
    p.labels.push_back(label.str());
  }
  return p;
}

std::vector<double> default_wheel_paths_m(const Surface& surface) {
  constexpr double kHalfTrack_m = 0.9;
  const double centre = 0.5 * (surface.y0_m + surface.y_max_m());
  if (surface.y_max_m() - surface.y0_m < 2.0 * kHalfTrack_m) return {centre};
  return {centre - kHalfTrack_m, centre + kHalfTrack_m};
}

}  // namespace ssrfleet::road
