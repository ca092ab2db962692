#include "road/envelopment.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "util/check.hpp"

namespace ssrfleet::road {

Eigen::Index envelopment_points(double dx_m, double base_length_m) {
  check_positive("envelop", "dx_m", dx_m);
  check_nonnegative("envelop", "base_length_m", base_length_m);
  return 2 * static_cast<Eigen::Index>(std::llround(base_length_m / (2.0 * dx_m))) + 1;
}

Eigen::ArrayXd envelop(const Eigen::ArrayXd& profile_m, double dx_m, double base_length_m) {
  const Eigen::Index h = (envelopment_points(dx_m, base_length_m) - 1) / 2;
  const Eigen::Index n = profile_m.size();
  if (h == 0) return profile_m;
  Eigen::ArrayXd out(n);
  // A direct sum per sample (N is ~7): exact to rounding, unlike a running sum whose error grows
  // along the profile.
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index hi = std::min({h, i, n - 1 - i});
    out(i) = profile_m.segment(i - hi, 2 * hi + 1).mean();
  }
  return out;
}

Surface envelop(const Surface& surface, double base_length_m) {
  Surface out = surface;
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    out.height_m.col(j) = envelop(Eigen::ArrayXd(surface.height_m.col(j)), surface.dx_m, base_length_m);
  }
  return out;
}

double envelopment_gain(double n_cpm, double dx_m, double base_length_m) {
  const auto points = static_cast<double>(envelopment_points(dx_m, base_length_m));
  const double phase = std::numbers::pi * n_cpm * dx_m;
  const double denominator = points * std::sin(phase);
  if (std::abs(denominator) < 1e-300) return 1.0;  // n = 0 (or a multiple of 1/dx): all N terms add
  return std::sin(points * phase) / denominator;
}

}  // namespace ssrfleet::road
