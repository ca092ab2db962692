#include "road/surface_summary.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "road/iri.hpp"
#include "road/wheel_path.hpp"
#include "util/check.hpp"

namespace ssrfleet::road {

SurfaceSummary summarize(const Surface& surface, double iri_step_m) {
  check_positive("summarize", "iri_step_m", iri_step_m);
  SurfaceSummary s;
  s.name = surface.name;
  s.samples = surface.samples();
  s.lines = surface.lines();
  s.dx_m = surface.dx_m;
  s.dy_m = surface.dy_m;
  s.length_m = surface.length_m();
  s.width_m = surface.y_max_m() - surface.y0_m;
  if (surface.height_m.size() > 0) {
    s.rms_height_m = std::sqrt((surface.height_m - surface.height_m.mean()).square().mean());
  }

  s.psd_band_lo_cpm = std::max(0.05, 4.0 / s.length_m);
  s.psd_band_hi_cpm = std::min(5.0, 0.25 / surface.dx_m);
  if (surface.samples() >= 4 && s.psd_band_hi_cpm > 2.0 * s.psd_band_lo_cpm) {
    try {
      s.psd = fit_psd(surface, s.psd_band_lo_cpm, s.psd_band_hi_cpm);
    } catch (const std::invalid_argument&) {
      s.psd = PsdFit{};  // too few frequency bins for a fit: reported as bins = 0
    }
  }

  const Eigen::Index k = iri_smoothing_points(surface.dx_m);
  if (surface.samples() >= k + 1) {
    const double width = s.width_m;
    const auto steps = static_cast<long>(std::floor(width / iri_step_m + 1e-9));
    for (long i = 0; i <= steps; ++i) {
      const double z = std::min(surface.y0_m + static_cast<double>(i) * iri_step_m, surface.y_max_m());
      s.iri_by_position.emplace_back(z, iri_m_per_km(wheel_path(surface, z), surface.dx_m));
    }
    double sum = 0.0;
    s.iri_min_m_per_km = s.iri_by_position.front().second;
    s.iri_max_m_per_km = s.iri_min_m_per_km;
    for (const auto& [z, iri] : s.iri_by_position) {
      sum += iri;
      s.iri_min_m_per_km = std::min(s.iri_min_m_per_km, iri);
      s.iri_max_m_per_km = std::max(s.iri_max_m_per_km, iri);
    }
    s.iri_mean_m_per_km = sum / static_cast<double>(s.iri_by_position.size());
  }
  return s;
}

std::string to_text(const SurfaceSummary& s) {
  std::ostringstream os;
  os << "road surface " << (s.name.empty() ? "(unnamed)" : s.name) << "\n";
  os << "  grid        " << s.samples << " x " << s.lines << " samples, dx " << s.dx_m << " m, dy " << s.dy_m
     << " m (" << s.length_m << " m long, " << s.width_m << " m wide)\n";
  os << std::setprecision(3);
  os << "  rms height  " << s.rms_height_m * 1e3 << " mm\n";
  if (s.psd.bins > 0) {
    os << "  PSD fit     G_d(" << s.psd.n0_cpm << " cycle/m) = " << s.psd.gd_n0_m3 * 1e6 << "e-6 m^3, w = "
       << s.psd.waviness << " (" << s.psd_band_lo_cpm << "-" << s.psd_band_hi_cpm << " cycle/m, " << s.psd.bins
       << " bins)\n";
  } else {
    os << "  PSD fit     none (surface too short or too coarse)\n";
  }
  if (!s.iri_by_position.empty()) {
    os << "  IRI         min " << s.iri_min_m_per_km << ", mean " << s.iri_mean_m_per_km << ", max "
       << s.iri_max_m_per_km << " m/km over " << s.iri_by_position.size() << " lateral positions\n";
    for (const auto& [z, iri] : s.iri_by_position) os << "    z = " << z << " m: " << iri << " m/km\n";
  }
  return os.str();
}

nlohmann::json to_json(const SurfaceSummary& s) {
  nlohmann::json iri_positions = nlohmann::json::array();
  for (const auto& [z, iri] : s.iri_by_position) iri_positions.push_back({{"z_m", z}, {"iri_m_per_km", iri}});
  return {
      {"name", s.name},
      {"samples", s.samples},
      {"lines", s.lines},
      {"dx_m", s.dx_m},
      {"dy_m", s.dy_m},
      {"length_m", s.length_m},
      {"width_m", s.width_m},
      {"rms_height_m", s.rms_height_m},
      {"psd_fit",
       {{"gd_n0_m3", s.psd.gd_n0_m3},
        {"waviness", s.psd.waviness},
        {"n0_cpm", s.psd.n0_cpm},
        {"bins", s.psd.bins},
        {"band_lo_cpm", s.psd_band_lo_cpm},
        {"band_hi_cpm", s.psd_band_hi_cpm}}},
      {"iri",
       {{"by_position", iri_positions},
        {"min_m_per_km", s.iri_min_m_per_km},
        {"mean_m_per_km", s.iri_mean_m_per_km},
        {"max_m_per_km", s.iri_max_m_per_km}}},
  };
}

}  // namespace ssrfleet::road
