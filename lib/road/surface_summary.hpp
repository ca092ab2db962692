// A one-look description of a road for reports and the command line: geometry, missing cells,
// height statistics, the fitted ISO 8608 power law and its roughness class (roughness_class.hpp,
// labelled with the table used), the IRI of the wheel paths and across lateral positions. A set
// of longitudinal profiles (an ERD file) gets the same summary with each profile a wheel path.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "road/longitudinal_profiles.hpp"
#include "road/psd_estimate.hpp"
#include "road/roughness_class.hpp"
#include "road/surface.hpp"

namespace ssrfleet::road {

struct WheelPathRoughness {
  std::string label;           // "z=1.6m", or a profile's name
  double z_m = 0.0;            // lateral position; NaN for a profile without one
  double iri_m_per_km = 0.0;
};

struct SurfaceSummary {
  std::string name;
  Eigen::Index samples = 0;
  Eigen::Index lines = 0;              // lateral lines, or profiles
  double dx_m = 0.0;
  double dy_m = 0.0;                   // 0 for profiles (no lateral grid)
  double length_m = 0.0;
  double width_m = 0.0;                // 0 for profiles
  Eigen::Index missing_cells = 0;
  double rms_height_m = 0.0;           // about the mean of all measured heights
  PsdFit psd;                          // along travel, averaged over the complete lines
  double psd_band_lo_cpm = 0.0;        // band the fit used
  double psd_band_hi_cpm = 0.0;
  RoughnessClass roughness_class;      // of psd.gd_n0_m3; label empty when there is no fit
  std::vector<WheelPathRoughness> wheel_paths;
  // (z_m, iri_m_per_km); the IRI is NaN where the path crosses missing cells (JSON null)
  std::vector<std::pair<double, double>> iri_by_position;
  double iri_min_m_per_km = 0.0;       // over the positions with an IRI
  double iri_mean_m_per_km = 0.0;
  double iri_max_m_per_km = 0.0;
};

struct SummaryOptions {
  double iri_step_m = 0.5;             // spacing of iri_by_position
  std::vector<double> wheel_paths_m;   // empty: default_wheel_paths_m(surface) (wheel_path.hpp)
  RoughnessTable table = RoughnessTable::iso8608_1995;
};

// PSD fit band: [max(0.05, 4 / length), min(5, 0.5 * Nyquist)] cycle/m (at least 4 cycles in
// the lowest bin's wavelength; half the Nyquist frequency to keep clear of the anti-alias edge);
// no fit (zeros, bins = 0, no class) when that band is empty or too narrow, or no line is
// complete. IRI (of the raw, unenveloped lines: the IRI applies its own 0.25 m smoothing) at
// z = y0, y0 + step, ... <= y_max, and at the wheel paths. A wheel path that crosses a missing
// cell is a DataError (wheel_path.hpp: complete_wheel_path).
SurfaceSummary summarize(const Surface& surface, const SummaryOptions& options);
SurfaceSummary summarize(const Surface& surface, double iri_step_m = 0.5);
// Each profile is a wheel path; no lateral grid, so no iri_by_position.
SurfaceSummary summarize(const LongitudinalProfiles& profiles, RoughnessTable table = RoughnessTable::iso8608_1995);

std::string to_text(const SurfaceSummary& summary);
nlohmann::json to_json(const SurfaceSummary& summary);

}  // namespace ssrfleet::road
