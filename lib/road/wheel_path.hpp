// The wheel path at lateral position z (DESIGN.md §1): linear interpolation between the two
// nearest lateral lines. A position outside the surface is an error, never a clamp: a truck
// driving off the measured carpet is a mistake in the inputs.
#pragma once

#include <Eigen/Core>

#include "road/surface.hpp"

namespace ssrfleet::road {

// path = (1 - weight_b) * line(line_a) + weight_b * line(line_b), weight_b in [0, 1].
struct LateralBracket {
  Eigen::Index line_a = 0;
  Eigen::Index line_b = 0;
  double weight_b = 0.0;
};

// z within 1e-9 line spacings of a line snaps onto it (weight 0), so z = surface.lateral_m(j)
// returns line j exactly despite rounding in y0 + j dy. z outside [y0, y_max] (or not finite) ->
// std::out_of_range naming z and the surface's lateral range.
LateralBracket bracket(const Surface& surface, double z_m);

Eigen::ArrayXd wheel_path(const Surface& surface, double z_m);

}  // namespace ssrfleet::road
