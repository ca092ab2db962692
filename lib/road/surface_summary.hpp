// A one-look description of a road surface for reports and the command line: geometry, height
// statistics, the fitted ISO 8608 power law and the IRI across lateral positions.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "road/psd_estimate.hpp"
#include "road/surface.hpp"

namespace ssrfleet::road {

struct SurfaceSummary {
  std::string name;
  Eigen::Index samples = 0;
  Eigen::Index lines = 0;
  double dx_m = 0.0;
  double dy_m = 0.0;
  double length_m = 0.0;
  double width_m = 0.0;
  double rms_height_m = 0.0;           // about the mean of all heights
  PsdFit psd;                          // along travel, averaged over lines
  double psd_band_lo_cpm = 0.0;        // band the fit used
  double psd_band_hi_cpm = 0.0;
  std::vector<std::pair<double, double>> iri_by_position;  // (z_m, iri_m_per_km)
  double iri_min_m_per_km = 0.0;
  double iri_mean_m_per_km = 0.0;
  double iri_max_m_per_km = 0.0;
};

// PSD fit band: [max(0.05, 4 / length), min(5, 0.5 * Nyquist)] cycle/m (at least 4 cycles in
// the lowest bin's wavelength; half the Nyquist frequency to keep clear of the anti-alias edge);
// no fit (zeros, bins = 0) when that band is empty or too narrow. IRI (of the raw, unenveloped
// lines: the IRI applies its own 0.25 m smoothing) at z = y0, y0 + step, ... <= y_max.
SurfaceSummary summarize(const Surface& surface, double iri_step_m = 0.5);

std::string to_text(const SurfaceSummary& summary);
nlohmann::json to_json(const SurfaceSummary& summary);

}  // namespace ssrfleet::road
