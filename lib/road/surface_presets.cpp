#include "road/surface_presets.hpp"

#include <algorithm>
#include <cctype>

#include "util/errors.hpp"

namespace ssrfleet::road {

namespace {
bool equal_ignoring_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::toupper(static_cast<unsigned char>(x)) == std::toupper(static_cast<unsigned char>(y));
         });
}
}  // namespace

const std::vector<SurfacePreset>& surface_presets() {
  static const std::vector<SurfacePreset> presets{
      {"AS1", 20e-6, 1, "B", "A"},
      {"AS2", 20e-6, 2, "B", "A"},
      {"AS3", 64e-6, 3, "C", "B"},
  };
  return presets;
}

bool is_preset_name(std::string_view name) {
  const auto& presets = surface_presets();
  return std::any_of(presets.begin(), presets.end(),
                     [&](const SurfacePreset& p) { return equal_ignoring_case(p.name, name); });
}

const SurfacePreset& find_preset(std::string_view name) {
  for (const auto& p : surface_presets()) {
    if (equal_ignoring_case(p.name, name)) return p;
  }
  std::string known;
  for (const auto& p : surface_presets()) known += (known.empty() ? "" : ", ") + p.name;
  throw UsageError("unknown road surface preset '" + std::string(name) + "'; the presets are " + known +
                   " (or give a road-surface CSV file)");
}

SurfaceSpec preset_spec(std::string_view name) {
  SurfaceSpec spec;
  spec.gd_n0_m3 = find_preset(name).gd_n0_m3;
  return spec;
}

Surface preset_surface(std::string_view name) {
  const SurfacePreset& preset = find_preset(name);
  Surface surface = generate_surface(preset_spec(name), preset.seed);
  surface.name = preset.name;
  return surface;
}

}  // namespace ssrfleet::road
