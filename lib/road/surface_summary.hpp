// A one-look description of a road for reports and the command line: geometry, missing cells
// (how many, in which lines, over which x range), height statistics, the fitted ISO 8608 power
// law and its roughness class (roughness_class.hpp, labelled with the table used), the IRI of the
// wheel paths and across lateral positions. A road with holes is described as well as a whole
// one: its roughness is that of the measured part, and an IRI across a hole is reported as
// unavailable with the reason. A set of longitudinal profiles (an ERD file) gets the same summary
// with each profile a wheel path.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "road/longitudinal_profiles.hpp"
#include "road/missing_map.hpp"
#include "road/psd_estimate.hpp"
#include "road/roughness_class.hpp"
#include "road/surface.hpp"

namespace ssrfleet::road {

struct WheelPathRoughness {
  std::string label;           // "z=1.6m", or a profile's name
  double z_m = 0.0;            // lateral position; NaN for a profile without one
  double iri_m_per_km = 0.0;   // NaN when unavailable
  std::string unavailable;     // why there is no IRI ("crosses 3 missing cells between x = ..."), or empty
};

struct SurfaceSummary {
  std::string name;
  Eigen::Index samples = 0;
  Eigen::Index lines = 0;              // lateral lines, or profiles
  double dx_m = 0.0;
  double dy_m = 0.0;                   // 0 for profiles (no lateral grid)
  double y0_m = 0.0;                   // lateral position of the first line
  double length_m = 0.0;
  double width_m = 0.0;                // 0 for profiles
  Eigen::Index missing_cells = 0;
  MissingMap missing;                  // where they are (missing_map.hpp)
  double rms_height_m = 0.0;           // about the mean of all measured heights
  PsdFit psd;                          // along travel, averaged over the lines of the measured part
  double psd_band_lo_cpm = 0.0;        // band the fit used
  double psd_band_hi_cpm = 0.0;
  Eigen::Index psd_lines = 0;          // lines the fit read (measured_part.hpp), over x_from..x_to
  double psd_x_from_m = 0.0;
  double psd_x_to_m = 0.0;
  bool psd_whole_lines = true;         // false: a stretch of the road, there being no unbroken line
  RoughnessClass roughness_class;      // of psd.gd_n0_m3; label empty when there is no fit
  std::vector<WheelPathRoughness> wheel_paths;
  // IRI at z = y0, y0 + step, ...; unavailable where the path crosses missing cells (JSON null)
  std::vector<WheelPathRoughness> iri_by_position;
  double iri_min_m_per_km = 0.0;       // over the positions with an IRI
  double iri_mean_m_per_km = 0.0;
  double iri_max_m_per_km = 0.0;
  Eigen::Index iri_positions_measured = 0;  // positions with an IRI
};

struct SummaryOptions {
  double iri_step_m = 0.5;             // spacing of iri_by_position
  std::vector<double> wheel_paths_m;   // empty: default_wheel_paths_m(surface) (wheel_path.hpp)
  RoughnessTable table = RoughnessTable::iso8608_1995;
};

// The PSD is fitted on the measured part (measured_part.hpp): the unbroken lines, or, when every
// line has a hole, the longest unbroken stretch. Fit band: [max(0.05, 4 / length), min(5, 0.5 *
// Nyquist)] cycle/m, length that of the part (at least 4 cycles in the lowest bin's wavelength;
// half the Nyquist frequency to keep clear of the anti-alias edge); no fit (zeros, bins = 0, no
// class) when that band is empty or too narrow, or nothing is measured. IRI (of the raw,
// unenveloped lines: the IRI applies its own 0.25 m smoothing) at z = y0, y0 + step, ... <= y_max,
// and at the wheel paths. A path that crosses missing cells has no IRI: NaN, and `unavailable`
// says how many cells it crosses and over which x range; a summary never refuses a road for its
// holes (a wheel path outside the surface is still std::out_of_range).
SurfaceSummary summarize(const Surface& surface, const SummaryOptions& options);
SurfaceSummary summarize(const Surface& surface, double iri_step_m = 0.5);
// Each profile is a wheel path; no lateral grid, so no iri_by_position.
SurfaceSummary summarize(const LongitudinalProfiles& profiles, RoughnessTable table = RoughnessTable::iso8608_1995);

std::string to_text(const SurfaceSummary& summary);
nlohmann::json to_json(const SurfaceSummary& summary);

}  // namespace ssrfleet::road
