#include "road/surface_summary.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "road/iri.hpp"
#include "road/measured_part.hpp"
#include "road/missing_cells.hpp"
#include "road/missing_map.hpp"
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

// The PSD fit over the measured part (measured_part.hpp), and the roughness class of its level.
void fit_roughness(const Surface& surface, RoughnessTable table, SurfaceSummary& s) {
  const MeasuredPart part = measured_part(surface);
  s.psd_whole_lines = part.whole_lines;
  s.psd_lines = static_cast<Eigen::Index>(part.lines.size());
  s.psd_x_from_m = surface.dx_m * static_cast<double>(part.row_begin);
  s.psd_x_to_m = surface.dx_m * static_cast<double>(std::max<Eigen::Index>(part.row_begin, part.row_end - 1));
  if (part.lines.empty()) return;
  const double length_m = s.psd_x_to_m - s.psd_x_from_m;
  s.psd_band_hi_cpm = std::min(5.0, 0.25 / surface.dx_m);
  if (!(length_m > 0.0)) return;
  s.psd_band_lo_cpm = std::max(0.05, 4.0 / length_m);
  if (part.row_end - part.row_begin < 4 || !(s.psd_band_hi_cpm > 2.0 * s.psd_band_lo_cpm)) return;
  try {
    s.psd = fit_psd(part.whole_lines && part.lines.size() == static_cast<std::size_t>(surface.lines())
                        ? surface
                        : extract(surface, part),
                    s.psd_band_lo_cpm, s.psd_band_hi_cpm);
  } catch (const std::invalid_argument&) {
    s.psd = PsdFit{};  // too few frequency bins for a fit: reported as bins = 0
    return;
  }
  if (s.psd.gd_n0_m3 > 0.0 && std::isfinite(s.psd.gd_n0_m3)) s.roughness_class = roughness_class(s.psd.gd_n0_m3, table);
}

// The IRI of the wheel path at z, or why there is none.
WheelPathRoughness path_roughness(const Surface& surface, double z_m, std::string label) {
  WheelPathRoughness w{std::move(label), z_m, std::numeric_limits<double>::quiet_NaN(), {}};
  const MissingCells missing = missing_on_path(surface, z_m);
  if (missing.count > 0) w.unavailable = "crosses " + describe_span(missing, surface);
  else w.iri_m_per_km = iri_m_per_km(wheel_path(surface, z_m), surface.dx_m);
  return w;
}

std::string path_label(double z_m) {
  std::ostringstream label;
  label.precision(4);
  label << "z=" << z_m << "m";
  return label.str();
}

void iri_statistics(SurfaceSummary& s) {
  double sum = 0.0;
  int n = 0;
  s.iri_min_m_per_km = std::numeric_limits<double>::infinity();
  s.iri_max_m_per_km = -std::numeric_limits<double>::infinity();
  for (const WheelPathRoughness& p : s.iri_by_position) {
    if (std::isnan(p.iri_m_per_km)) continue;
    sum += p.iri_m_per_km;
    ++n;
    s.iri_min_m_per_km = std::min(s.iri_min_m_per_km, p.iri_m_per_km);
    s.iri_max_m_per_km = std::max(s.iri_max_m_per_km, p.iri_m_per_km);
  }
  s.iri_positions_measured = n;
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
  s.y0_m = surface.y0_m;
  s.length_m = surface.length_m();
  s.width_m = surface.y_max_m() - surface.y0_m;
  s.missing = map_missing(surface);
  s.missing_cells = s.missing.cells;
  s.rms_height_m = rms_of_measured(surface.height_m);
  fit_roughness(surface, options.table, s);

  const Eigen::Index k = iri_smoothing_points(surface.dx_m);
  if (surface.samples() < k + 1) return s;
  const std::vector<double> paths = options.wheel_paths_m.empty() ? default_wheel_paths_m(surface) : options.wheel_paths_m;
  for (const double z : paths) s.wheel_paths.push_back(path_roughness(surface, z, path_label(z)));
  const auto steps = static_cast<long>(std::floor(s.width_m / options.iri_step_m + 1e-9));
  for (long i = 0; i <= steps; ++i) {
    const double z = std::min(surface.y0_m + static_cast<double>(i) * options.iri_step_m, surface.y_max_m());
    s.iri_by_position.push_back(path_roughness(surface, z, path_label(z)));
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
  s.missing = map_missing(as_lines);
  s.missing_cells = s.missing.cells;
  s.rms_height_m = rms_of_measured(profiles.height_m);
  fit_roughness(as_lines, table, s);
  if (profiles.samples() >= iri_smoothing_points(profiles.dx_m) + 1) {
    for (Eigen::Index k = 0; k < profiles.profiles(); ++k) {
      WheelPathRoughness w{profiles.labels[static_cast<std::size_t>(k)], std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::quiet_NaN(), {}};
      const MissingCells missing = find_missing(as_lines, 0, as_lines.samples(), k, k + 1);
      if (missing.count > 0) w.unavailable = "has " + describe_span(missing, as_lines);
      else w.iri_m_per_km = iri_m_per_km(profiles.height_m.col(k), profiles.dx_m);
      s.wheel_paths.push_back(std::move(w));
    }
  }
  return s;
}

std::string to_text(const SurfaceSummary& s) {
  std::ostringstream os;
  const bool surface = s.dy_m > 0.0;
  os << (surface ? "road surface " : "road profiles ") << (s.name.empty() ? "(unnamed)" : s.name) << "\n";
  if (surface) {
    os << "  grid        " << s.samples << " x " << s.lines << " samples, dx " << s.dx_m << " m, dy " << s.dy_m
       << " m (" << s.length_m << " m long, " << s.width_m << " m wide)\n";
  } else {
    os << "  profiles    " << s.lines << " of " << s.samples << " samples, dx " << s.dx_m << " m (" << s.length_m
       << " m long)\n";
  }
  os << "  missing     " << s.missing_cells << " cells";
  if (s.missing_cells > 0) {
    os << " in " << s.missing.lines_with_missing << " of " << s.lines << (surface ? " lines" : " profiles");
    if (surface) {
      os << ":\n" << describe_map(s.missing, {s.dx_m, s.y0_m, s.dy_m}, "    ");
    } else {
      os << "\n";
    }
  } else {
    os << "\n";
  }
  os << std::setprecision(3);
  os << "  rms height  " << s.rms_height_m * 1e3 << " mm" << (s.missing_cells > 0 ? " (of the measured cells)" : "")
     << "\n";
  if (s.psd.bins > 0) {
    os << "  PSD fit     G_d(" << s.psd.n0_cpm << " cycle/m) = " << s.psd.gd_n0_m3 * 1e6 << "e-6 m^3, w = "
       << s.psd.waviness << " (" << s.psd_band_lo_cpm << "-" << s.psd_band_hi_cpm << " cycle/m, " << s.psd.bins
       << " bins)\n";
    if (s.missing_cells > 0) {
      os << std::setprecision(6) << "              on " << s.psd_lines << " of " << s.lines
         << (surface ? " lines" : " profiles");
      if (s.psd_whole_lines) os << " (those with no missing cell)\n";
      else os << " over x = " << s.psd_x_from_m << " .. " << s.psd_x_to_m << " m (the longest stretch clear of holes)\n";
      os << std::setprecision(3);
    }
    os << "  class       " << s.roughness_class.label << " in " << s.roughness_class.table << "\n";
  } else {
    os << "  PSD fit     none (";
    if (s.psd_lines == 0) os << "nothing measured";
    else if (!s.psd_whole_lines)
      os << std::setprecision(6) << "the longest stretch clear of holes, x = " << s.psd_x_from_m << " .. "
         << s.psd_x_to_m << " m, is too short" << std::setprecision(3);
    else os << "surface too short or too coarse";
    os << ")\n";
  }
  for (const WheelPathRoughness& w : s.wheel_paths) {
    os << "  wheel path  " << w.label << ": IRI ";
    if (w.unavailable.empty()) os << w.iri_m_per_km << " m/km\n";
    else os << "unavailable: it " << w.unavailable << "\n";
  }
  if (!s.iri_by_position.empty()) {
    const std::size_t n = s.iri_by_position.size();
    os << "  IRI         ";
    if (s.iri_positions_measured > 0) {
      os << "min " << s.iri_min_m_per_km << ", mean " << s.iri_mean_m_per_km << ", max " << s.iri_max_m_per_km
         << " m/km over ";
    } else {
      os << "unavailable at all ";
    }
    if (s.iri_positions_measured > 0 && static_cast<std::size_t>(s.iri_positions_measured) < n) {
      os << s.iri_positions_measured << " of ";
    }
    os << n << " lateral positions\n";
    for (const WheelPathRoughness& p : s.iri_by_position) {
      os << "    z = " << p.z_m << " m: ";
      if (p.unavailable.empty()) os << p.iri_m_per_km << " m/km\n";
      else os << "unavailable (" << p.unavailable << ")\n";
    }
  }
  return os.str();
}

nlohmann::json to_json(const SurfaceSummary& s) {
  const auto roughness_json = [](const WheelPathRoughness& w, bool with_label) {
    nlohmann::json j = {{"z_m", number_or_null(w.z_m)}, {"iri_m_per_km", number_or_null(w.iri_m_per_km)}};
    if (with_label) j["label"] = w.label;
    if (!w.unavailable.empty()) j["unavailable"] = w.unavailable;
    return j;
  };
  nlohmann::json iri_positions = nlohmann::json::array();
  for (const WheelPathRoughness& p : s.iri_by_position) iri_positions.push_back(roughness_json(p, false));
  nlohmann::json wheel_paths = nlohmann::json::array();
  for (const WheelPathRoughness& w : s.wheel_paths) wheel_paths.push_back(roughness_json(w, true));
  nlohmann::json roughness = nullptr;
  if (!s.roughness_class.label.empty()) {
    roughness = {{"class", s.roughness_class.label},
                 {"table", s.roughness_class.table},
                 {"gd_n0_lower_m3", s.roughness_class.lower_m3},
                 {"gd_n0_upper_m3", number_or_null(std::isinf(s.roughness_class.upper_m3)
                                                       ? std::numeric_limits<double>::quiet_NaN()
                                                       : s.roughness_class.upper_m3)}};
  }
  nlohmann::json missing = to_json(s.missing, {s.dx_m, s.y0_m, s.dy_m});
  if (!(s.dy_m > 0.0)) {  // profiles: no lateral positions
    missing.erase("clear_of_holes");
    for (nlohmann::json& g : missing.at("groups")) {
      g.erase("y_from_m");
      g.erase("y_to_m");
    }
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
      {"missing", missing},
      {"rms_height_m", s.rms_height_m},
      {"psd_fit",
       {{"gd_n0_m3", s.psd.gd_n0_m3},
        {"waviness", s.psd.waviness},
        {"n0_cpm", s.psd.n0_cpm},
        {"bins", s.psd.bins},
        {"band_lo_cpm", s.psd_band_lo_cpm},
        {"band_hi_cpm", s.psd_band_hi_cpm},
        {"lines", s.psd_lines},
        {"whole_lines", s.psd_whole_lines},
        {"x_from_m", s.psd_x_from_m},
        {"x_to_m", s.psd_x_to_m}}},
      {"roughness_class", roughness},
      {"iri",
       {{"wheel_paths", wheel_paths},
        {"by_position", iri_positions},
        {"positions_measured", s.iri_positions_measured},
        {"min_m_per_km", s.iri_min_m_per_km},
        {"mean_m_per_km", s.iri_mean_m_per_km},
        {"max_m_per_km", s.iri_max_m_per_km}}},
  };
}

}  // namespace ssrfleet::road
