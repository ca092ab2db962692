// Where a road surface comes from on the command line: a preset name (AS1, AS2, AS3) or the path
// of a measured surface, a road CSV (docs/site-data.md) or an ASAM OpenCRG file (.crg, any of its four
// data types), so a measured surface can stand in for a preset. The file's kind is read from its
// content (road/road_format.hpp). An ERD file holds longitudinal profiles, not a surface: it is
// refused here with a UsageError saying so (`ssrfleet road FILE.erd` reports its roughness).
#pragma once

#include <iosfwd>
#include <string>

#include "road/surface.hpp"

namespace ssrfleet::site {

// `warnings`, if given, receives one "warning: ..." line for each thing an OpenCRG file holds that
// the surface leaves out (curvature, slope, banking, modifiers, unknown channels) and for its
// missing cells; the library itself prints nothing.
road::Surface load_road(const std::string& preset_or_path, std::ostream* warnings = nullptr);

}  // namespace ssrfleet::site
