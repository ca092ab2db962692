#include "site/road_source.hpp"

#include <ostream>
#include <utility>

#include "road/crg_reader.hpp"
#include "road/road_format.hpp"
#include "road/surface_csv.hpp"
#include "road/surface_presets.hpp"
#include "util/errors.hpp"

namespace ssrfleet::site {

road::Surface load_road(const std::string& preset_or_path, std::ostream* warnings) {
  if (road::is_preset_name(preset_or_path)) return road::preset_surface(preset_or_path);
  switch (road::detect_road_format(preset_or_path)) {
    case road::RoadFileFormat::csv:
      return road::read_surface_csv_file(preset_or_path);
    case road::RoadFileFormat::erd:
      throw UsageError("'" + preset_or_path +
                       "' is an ERD file of longitudinal profiles: it does not say where across the road each profile "
                       "lies, so it cannot stand for the 3-D surface trucks drive over; use a preset, a road CSV or an "
                       "OpenCRG file (ssrfleet road '" + preset_or_path + "' reports its roughness)");
    case road::RoadFileFormat::crg:
      break;
  }
  road::CrgRoad crg = road::read_crg_file(preset_or_path);
  if (warnings) {
    for (const std::string& w : crg.report.warnings) *warnings << "warning: road '" << preset_or_path << "': " << w << "\n";
    if (crg.report.missing_cells > 0) {
      *warnings << "warning: road '" << preset_or_path << "': " << crg.report.missing_cells
                << " missing cells; a wheel path or the trucks' stretch that crosses one is refused\n";
    }
  }
  return std::move(crg.surface);
}

}  // namespace ssrfleet::site
