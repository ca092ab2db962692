// The wheel path at lateral position z (docs/model.md): linear interpolation between the two
// nearest lateral lines. A position outside the surface is an error, never a clamp: a truck
// driving off the measured carpet is a mistake in the inputs.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "road/longitudinal_profiles.hpp"
#include "road/missing_cells.hpp"
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

// The missing cells a wheel path at z reads (those of the one or two lines it interpolates).
MissingCells missing_on_path(const Surface& surface, double z_m);

// The wheel path at z, refusing one that reads a missing cell (missing_cells.hpp): DataError
// naming the surface, z, and how many missing cells it crosses and where the first is.
Eigen::ArrayXd complete_wheel_path(const Surface& surface, double z_m);

// The wheel paths at zs as longitudinal profiles (to write as ERD), labelled "z=<z>m";
// complete_wheel_path's errors.
LongitudinalProfiles wheel_path_profiles(const Surface& surface, const std::vector<double>& zs_m);

// The wheel paths roughness is reported for when none are named: a truck's two wheel paths, a
// 1.8 m track centred on the surface (centre -/+ 0.9 m), or the centre line alone when the
// surface is narrower than the track.
std::vector<double> default_wheel_paths_m(const Surface& surface);

}  // namespace ssrfleet::road
