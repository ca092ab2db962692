#include "site/road_source.hpp"

#include "road/surface_csv.hpp"
#include "road/surface_presets.hpp"

namespace ssrfleet::site {

road::Surface load_road(const std::string& preset_or_path) {
  if (road::is_preset_name(preset_or_path)) return road::preset_surface(preset_or_path);
  return road::read_surface_csv_file(preset_or_path);
}

}  // namespace ssrfleet::site
