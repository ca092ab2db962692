// Where a road surface comes from on the command line: a preset name (AS1, AS2, AS3) or the
// path of a road-surface CSV (DESIGN.md §7), so a measured surface can stand in for a preset.
#pragma once

#include <string>

#include "road/surface.hpp"

namespace ssrfleet::site {

road::Surface load_road(const std::string& preset_or_path);

}  // namespace ssrfleet::site
