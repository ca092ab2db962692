// The named road surfaces of docs/model.md: AS1, AS2 (G_d(n0) = 20e-6 m^3, seeds 1 and 2) and AS3
// (64e-6 m^3, seed 3), all with the default SurfaceSpec (100 m x 5 m at 0.05 m, w = 2,
// n0 = 0.1 cycle/m, band 0.01-10 cycle/m).
//
// Roughness class convention: the paper (Wilson, Harris & O'Brien) calls 20e-6 m^3 "class B" and
// 64e-6 m^3 "class C", which follows an older class table. In ISO 8608:1995 class B spans
// 32e-6-128e-6 m^3 (geometric mean 64e-6), so 20e-6 is class A there and 64e-6 is class B. We
// keep the paper's values and say "paper class" when naming them.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "road/surface.hpp"
#include "road/surface_generator.hpp"

namespace ssrfleet::road {

struct SurfacePreset {
  std::string name;          // canonical (upper case)
  double gd_n0_m3;           // G_d(n0)
  std::uint64_t seed;
  std::string paper_class;   // the class the paper gives it (older table)
  std::string iso8608_class; // its class in ISO 8608:1995
};

const std::vector<SurfacePreset>& surface_presets();

// Case-insensitive.
bool is_preset_name(std::string_view name);

// The spec and seed of a preset; unknown name -> ssrfleet::UsageError listing the presets.
const SurfacePreset& find_preset(std::string_view name);
SurfaceSpec preset_spec(std::string_view name);

// Generates the preset (about 0.1 s for 2001 x 101; nothing is cached). surface.name is the
// canonical name.
Surface preset_surface(std::string_view name);

}  // namespace ssrfleet::road
