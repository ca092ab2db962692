#include "road/surface_summary.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "road/iri.hpp"
#include "road/missing_cells.hpp"
#include "road/wheel_path.hpp"
#include "util/check.hpp"

namespace ssrfleet::road {

namespace {

// RMS about the mean of the measured (non-missing) heights.
double rms_of_measured(const Eigen::ArrayXXd& heights) {
  double sum = 0.0, sum_sq = 0.0;
  Eigen::Index n = 0;
  for (Eigen::Index k = 0; k < heights.size(); ++k) {
    const double h = heights.data()[k];
    if (is_missing(h)) continue;
    sum += h;
    ++n;
  }
  if (n == 0) return 0.0;
  const double mean = sum / static_cast<double>(n);
  for (Eigen::Index k = 0; k < heights.size(); ++k) {
    const double h = heights.data()[k];
    if (!is_missing(h)) sum_sq += (h - mean) * (h - mean);
  }
  return std::sqrt(sum_sq / static_cast<double>(n));
}

// The PSD fit over the lines with no missing cell (a hole would leak into every frequency), and
// the roughness class of its level.
void fit_roughness(const Surface& surface, RoughnessTable table, SurfaceSummary& s) {
  s.psd_band_lo_cpm = std::max(0.05, 4.0 / s.length_m);
  s.psd_band_hi_cpm = std::min(5.0, 0.25 / surface.dx_m);
  if (surface.samples() < 4 || !(s.psd_band_hi_cpm > 2.0 * s.psd_band_lo_cpm)) return;
  Surface complete = surface;
  if (s.missing_cells > 0) {
    std::vector<Eigen::Index> keep;
    for (Eigen::Index j = 0; j < surface.lines(); ++j) {
      if (!surface.height_m.col(j).isNaN().any()) keep.push_back(j);
    }
    if (keep.empty()) return;
    complete.height_m.resize(surface.samples(), static_cast<Eigen::Index>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k) {
      complete.height_m.col(static_cast<Eigen::Index>(k)) = surface.height_m.col(keep[k]);
    }
  }
  try {
    s.psd = fit_psd(complete, s.psd_band_lo_cpm, s.psd_band_hi_cpm);
  } catch (const std::invalid_argument&) {
    s.psd = PsdFit{};  // too few frequency bins for a fit: reported as bins = 0
    return;
  }
  if (s.psd.gd_n0_m3 > 0.0 && std::isfinite(s.psd.gd_n0_m3)) s.roughness_class = roughness_class(s.psd.gd_n0_m3, table);
}

void iri_statistics(SurfaceSummary& s) {
  double sum = 0.0;
  int n = 0;
  s.iri_min_m_per_km = std::numeric_limits<double>::infinity();
  s.iri_max_m_per_km = -std::numeric_limits<double>::infinity();
  for (const auto& [z, iri] : s.iri_by_position) {
    if (std::isnan(iri)) continue;
    sum += iri;
    ++n;
    s.iri_min_m_per_km = std::min(s.iri_min_m_per_km, iri);
    s.iri_max_m_per_km = std::max(s.iri_max_m_per_km, iri);
  }
  if (n == 0) {
    s.iri_min_m_per_km = s.iri_max_m_per_km = 0.0;
    return;
  }
  s.iri_mean_m_per_km = sum / n;
}

nlohmann::json number_or_null(double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); }

}  // namespace

SurfaceSummary summarize(const Surface& surface, double iri_step_m) {
  SummaryOptions options;
  options.iri_step_m = iri_step_m;
  return summarize(surface, options);
}

SurfaceSummary summarize(const Surface& surface, const SummaryOptions& options) {
  check_positive("summarize", "iri_step_m", options.iri_step_m);
  SurfaceSummary s;
  s.name = surface.name;
  s.samples = surface.samples();
  s.lines = surface.lines();
  s.dx_m = surface.dx_m;
  s.dy_m = surface.dy_m;
  s.length_m = surface.length_m();
  s.width_m = surface.y_max_m() - surface.y0_m;
  s.missing_cells = find_missing(surface).count;
  s.rms_height_m = rms_of_measured(surface.height_m);
  fit_roughness(surface, options.table, s);

  const Eigen::Index k = iri_smoothing_points(surface.dx_m);
  if (surface.samples() < k + 1) return s;
  const std::vector<double> paths = options.wheel_paths_m.empty() ? default_wheel_paths_m(surface) : options.wheel_paths_m;
  for (const double z : paths) {
    const LongitudinalProfiles p = wheel_path_profiles(surface, {z});
    s.wheel_paths.push_back({p.labels.front(), z, iri_m_per_km(p.height_m.col(0), surface.dx_m)});
  }
  const auto steps = static_cast<long>(std::floor(s.width_m / options.iri_step_m + 1e-9));
  for (long i = 0; i <= steps; ++i) {
    const double z = std::min(surface.y0_m + static_cast<double>(i) * options.iri_step_m, surface.y_max_m());
    const Eigen::ArrayXd path = wheel_path(surface, z);
    const double iri = path.isNaN().any() ? std::numeric_limits<double>::quiet_NaN() : iri_m_per_km(path, surface.dx_m);
    s.iri_by_position.emplace_back(z, iri);
  }
  iri_statistics(s);
  return s;
}

SurfaceSummary summarize(const LongitudinalProfiles& profiles, RoughnessTable table) {
  Surface as_lines;  // the profiles side by side; the lateral grid is never used
  as_lines.name = profiles.name;
  as_lines.dx_m = profiles.dx_m;
  as_lines.dy_m = 1.0;
  as_lines.height_m = profiles.height_m;
  SurfaceSummary s;
  s.name = profiles.name;
  s.samples = profiles.samples();
  s.lines = profiles.profiles();
  s.dx_m = profiles.dx_m;
  s.length_m = profiles.length_m();
  s.missing_cells = find_missing(as_lines).count;
  s.rms_height_m = rms_of_measured(profiles.height_m);
  fit_roughness(as_lines, table, s);
  if (profiles.samples() >= iri_smoothing_points(profiles.dx_m) + 1) {
    for (Eigen::Index k = 0; k < profiles.profiles(); ++k) {
      s.wheel_paths.push_back({profiles.labels[static_cast<std::size_t>(k)], std::numeric_limits<double>::quiet_NaN(),
                               iri_m_per_km(profiles.height_m.col(k), profiles.dx_m)});
    }
  }
  return s;
}

std::string to_text(const SurfaceSummary& s) {
  std::ostringstream os;
  os << (s.dy_m > 0.0 ? "road surface " : "road profiles ") << (s.name.empty() ? "(unnamed)" : s.name) << "\n";
  if (s.dy_m > 0.0) {
    os << "  grid        " << s.samples << " x " << s.lines << " samples, dx " << s.dx_m << " m, dy " << s.dy_m
       << " m (" << s.length_m << " m long, " << s.width_m << " m wide)\n";
  } else {
    os << "  profiles    " << s.lines << " of " << s.samples << " samples, dx " << s.dx_m << " m (" << s.length_m
       << " m long)\n";
  }
  os << "  missing     " << s.missing_cells << " cells\n";
  os << std::setprecision(3);
  os << "  rms height  " << s.rms_height_m * 1e3 << " mm\n";
  if (s.psd.bins > 0) {
    os << "  PSD fit     G_d(" << s.psd.n0_cpm << " cycle/m) = " << s.psd.gd_n0_m3 * 1e6 << "e-6 m^3, w = "
       << s.psd.waviness << " (" << s.psd_band_lo_cpm << "-" << s.psd_band_hi_cpm << " cycle/m, " << s.psd.bins
       << " bins)\n";
    os << "  class       " << s.roughness_class.label << " in " << s.roughness_class.table << "\n";
  } else {
    os << "  PSD fit     none (surface too short or too coarse, or no line without missing cells)\n";
  }
  for (const WheelPathRoughness& w : s.wheel_paths) {
    os << "  wheel path  " << w.label << ": IRI " << w.iri_m_per_km << " m/km\n";
  }
  if (!s.iri_by_position.empty()) {
    os << "  IRI         min " << s.iri_min_m_per_km << ", mean " << s.iri_mean_m_per_km << ", max "
       << s.iri_max_m_per_km << " m/km over " << s.iri_by_position.size() << " lateral positions\n";
    for (const auto& [z, iri] : s.iri_by_position) {
      os << "    z = " << z << " m: ";
      if (std::isnan(iri)) os << "- (crosses missing cells)\n";
      else os << iri << " m/km\n";
    }
  }
  return os.str();
}

nlohmann::json to_json(const SurfaceSummary& s) {
  nlohmann::json iri_positions = nlohmann::json::array();
  for (const auto& [z, iri] : s.iri_by_position) iri_positions.push_back({{"z_m", z}, {"iri_m_per_km", number_or_null(iri)}});
  nlohmann::json wheel_paths = nlohmann::json::array();
  for (const WheelPathRoughness& w : s.wheel_paths) {
    wheel_paths.push_back({{"label", w.label}, {"z_m", number_or_null(w.z_m)}, {"iri_m_per_km", w.iri_m_per_km}});
  }
  nlohmann::json roughness = nullptr;
  if (!s.roughness_class.label.empty()) {
    roughness = {{"class", s.roughness_class.label},
                 {"table", s.roughness_class.table},
                 {"gd_n0_lower_m3", s.roughness_class.lower_m3},
                 {"gd_n0_upper_m3", number_or_null(std::isinf(s.roughness_class.upper_m3)
                                                       ? std::numeric_limits<double>::quiet_NaN()
                                                       : s.roughness_class.upper_m3)}};
  }
  return {
      {"name", s.name},
      {"samples", s.samples},
      {"lines", s.lines},
      {"dx_m", s.dx_m},
      {"dy_m", s.dy_m},
      {"length_m", s.length_m},
      {"width_m", s.width_m},
      {"missing_cells", s.missing_cells},
      {"rms_height_m", s.rms_height_m},
      {"psd_fit",
       {{"gd_n0_m3", s.psd.gd_n0_m3},
        {"waviness", s.psd.waviness},
        {"n0_cpm", s.psd.n0_cpm},
        {"bins", s.psd.bins},
        {"band_lo_cpm", s.psd_band_lo_cpm},
        {"band_hi_cpm", s.psd_band_hi_cpm}}},
      {"roughness_class", roughness},
      {"iri",
       {{"wheel_paths", wheel_paths},
        {"by_position", iri_positions},
        {"min_m_per_km", s.iri_min_m_per_km},
        {"mean_m_per_km", s.iri_mean_m_per_km},
        {"max_m_per_km", s.iri_max_m_per_km}}},
  };
}

}  // namespace ssrfleet::road
