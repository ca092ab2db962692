#include "road/crg_reader.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <sstream>

#include "road/crg_header.hpp"
#include "road/crg_payload.hpp"
#include "road/missing_cells.hpp"
#include "road/road_file.hpp"
#include "util/errors.hpp"

namespace ssrfleet::road {

namespace {

constexpr double kMaxCells = kMaxCrgCells;
constexpr double kGridTolerance = 1e-6;  // relative, on positions that should sit on a grid
constexpr double kStraightTolerance = 1e-9;

using Kind = CrgChannel::Kind;

std::string number_text(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

// Where the long sections go: the surface's lateral grid and, for each line of it, the payload
// columns it is read from (a and b with b's weight; a == b for a line that is a long section).
struct LateralLayout {
  double y0_m = 0.0;
  double dy_m = 0.0;
  std::vector<std::size_t> column_a, column_b;
  std::vector<double> weight_b;
  bool resampled = false;
  double original_min_step_m = 0.0;
};

LateralLayout lateral_layout(const CrgHeader& h, const std::string& source) {
  std::vector<std::size_t> sections;  // payload columns of the long sections
  for (std::size_t c = 0; c < h.channels.size(); ++c) {
    if (h.channels[c].kind == Kind::long_section) sections.push_back(c);
  }
  const std::size_t n = sections.size();
  if (n < 2) {
    throw DataError(source, h.definition_line, "$KD_DEFINITION",
                    "needs at least 2 long sections ('D:long section ...,m'), found " + std::to_string(n));
  }
  const CrgChannel& first = h.channels[sections.front()];
  for (const std::size_t c : sections) {
    if (h.channels[c].at_position != first.at_position) {
      throw DataError(
          source, h.channels[c].line, "D:" + h.channels[c].definition,
          "numbered long sections ('long section N') and placed ones ('long section at v = X') are mixed");
    }
  }
  LateralLayout layout;
  if (!first.at_position) {
    std::vector<std::size_t> by_number(n, SIZE_MAX);
    for (const std::size_t c : sections) {
      const CrgChannel& ch = h.channels[c];
      if (ch.number > static_cast<long>(n) ||
          by_number[static_cast<std::size_t>(ch.number - 1)] != SIZE_MAX) {
        throw DataError(source, ch.line, "D:" + ch.definition,
                        "long sections must be numbered 1 to " + std::to_string(n) + ", each once");
      }
      by_number[static_cast<std::size_t>(ch.number - 1)] = c;
    }
    const auto right = h.parameter("LONG_SECTION_V_RIGHT"), left = h.parameter("LONG_SECTION_V_LEFT"),
               inc = h.parameter("LONG_SECTION_V_INCREMENT");
    const double gaps = static_cast<double>(n - 1);
    if (inc) {
      if (!(inc->value > 0.0))
        throw DataError(source, inc->line, "LONG_SECTION_V_INCREMENT", "must be positive");
      layout.dy_m = inc->value;
    } else if (right && left) {
      layout.dy_m = (left->value - right->value) / gaps;
      if (!(layout.dy_m > 0.0)) {
        throw DataError(source, left->line, "LONG_SECTION_V_LEFT",
                        "must lie left of (above) LONG_SECTION_V_RIGHT");
      }
    } else {
      throw DataError(source, first.line, "D:" + first.definition,
                      "numbered long sections need LONG_SECTION_V_INCREMENT or both LONG_SECTION_V_RIGHT and "
                      "LONG_SECTION_V_LEFT in $ROAD_CRG");
    }
    layout.y0_m = right ? right->value : left ? left->value - gaps * layout.dy_m : -0.5 * gaps * layout.dy_m;
    if (right && left && inc) {
      const double span = (left->value - right->value) / inc->value;
      if (std::abs(span - gaps) > kGridTolerance * std::max(1.0, gaps)) {
        throw DataError(source, left->line, "LONG_SECTION_V_LEFT",
                        "counts disagree: V_RIGHT " + number_text(right->value) + " to V_LEFT " +
                            number_text(left->value) + " m at V_INCREMENT " + number_text(inc->value) +
                            " m makes " + number_text(span + 1.0) +
                            " long sections, $KD_DEFINITION defines " + std::to_string(n));
      }
    }
    layout.column_a = by_number;
    layout.column_b = by_number;
    layout.weight_b.assign(n, 0.0);
    return layout;
  }

  // Placed long sections: sort by v.
  std::sort(sections.begin(), sections.end(),
            [&](std::size_t a, std::size_t b) { return h.channels[a].v_m < h.channels[b].v_m; });
  std::vector<double> v(n);
  for (std::size_t k = 0; k < n; ++k) v[k] = h.channels[sections[k]].v_m;
  double min_step = std::numeric_limits<double>::infinity(), max_step = 0.0;
  for (std::size_t k = 1; k < n; ++k) {
    const double step = v[k] - v[k - 1];
    if (!(step > 0.0)) {
      const CrgChannel& ch = h.channels[sections[k]];
      throw DataError(source, ch.line, "D:" + ch.definition,
                      "two long sections at the same v = " + number_text(v[k]));
    }
    min_step = std::min(min_step, step);
    max_step = std::max(max_step, step);
  }
  layout.y0_m = v.front();
  if (max_step - min_step <= kGridTolerance * min_step) {
    layout.dy_m = (v.back() - v.front()) / static_cast<double>(n - 1);
    layout.column_a.assign(sections.begin(), sections.end());
    layout.column_b = layout.column_a;
    layout.weight_b.assign(n, 0.0);
    return layout;
  }
  // Uneven: every v must sit on the grid of the smallest step.
  const double lines_exact = (v.back() - v.front()) / min_step;
  if (lines_exact + 1.0 > 1e5) {
    throw DataError(source, first.line, "D:" + first.definition,
                    "uneven long sections would need over 1e5 lines");
  }
  for (std::size_t k = 0; k < n; ++k) {
    const double t = (v[k] - v.front()) / min_step;
    if (std::abs(t - std::round(t)) > 1e-6 * std::max(1.0, t)) {
      const CrgChannel& ch = h.channels[sections[k]];
      throw DataError(source, ch.line, "D:" + ch.definition,
                      "uneven long sections: v = " + number_text(v[k]) +
                          " m is not on the grid of the smallest spacing " + number_text(min_step) +
                          " m from v = " + number_text(v.front()) + " m");
    }
  }
  const auto lines = static_cast<std::size_t>(std::llround(lines_exact)) + 1;
  layout.dy_m = (v.back() - v.front()) / static_cast<double>(lines - 1);
  layout.resampled = true;
  layout.original_min_step_m = min_step;
  std::size_t k = 0;
  for (std::size_t j = 0; j < lines; ++j) {
    const double t = static_cast<double>(j);
    while (k + 1 < n && std::llround((v[k + 1] - v.front()) / layout.dy_m) <= static_cast<long long>(j)) ++k;
    const double tk = static_cast<double>(std::llround((v[k] - v.front()) / layout.dy_m));
    if (t == tk || k + 1 == n) {
      layout.column_a.push_back(sections[k]);
      layout.column_b.push_back(sections[k]);
      layout.weight_b.push_back(0.0);
    } else {
      const double tk1 = static_cast<double>(std::llround((v[k + 1] - v.front()) / layout.dy_m));
      layout.column_a.push_back(sections[k]);
      layout.column_b.push_back(sections[k + 1]);
      layout.weight_b.push_back((t - tk) / (tk1 - tk));
    }
  }
  return layout;
}

// Rows declared by REFERENCE_LINE_END_U, or 0 when it is not given.
std::size_t declared_rows(const CrgHeader& h, double increment, std::size_t channels,
                          const std::string& source) {
  const auto end = h.parameter("REFERENCE_LINE_END_U");
  if (!end) return 0;
  const auto start = h.parameter("REFERENCE_LINE_START_U");
  const double span = (end->value - (start ? start->value : 0.0)) / increment;
  if (!(span >= 1.0) || std::abs(span - std::round(span)) > kGridTolerance * std::max(1.0, span)) {
    throw DataError(
        source, end->line, "REFERENCE_LINE_END_U",
        "REFERENCE_LINE_END_U - START_U must be a whole number (>= 1) of REFERENCE_LINE_INCREMENT, found " +
            number_text(span) + " increments");
  }
  if ((std::round(span) + 1.0) * static_cast<double>(channels) > kMaxCells) {
    throw DataError(source, end->line, "REFERENCE_LINE_END_U",
                    "the header declares " + number_text(std::round(span) + 1.0) + " cross sections of " +
                        std::to_string(channels) +
                        " channels, more than the 1e8 values ssrfleet reads (a corrupt header?)");
  }
  return static_cast<std::size_t>(std::llround(span)) + 1;
}


// Fills the surface and keeps what the warnings need from the reference-line channels.
class SurfaceSink : public RowSink {
 public:
  SurfaceSink(const CrgHeader& h, const LateralLayout& layout, Surface& surface)
      : h_(h), layout_(layout), surface_(surface) {}
  void reserve(std::size_t rows) override {
    surface_.height_m.resize(static_cast<Eigen::Index>(rows),
                             static_cast<Eigen::Index>(layout_.column_a.size()));
  }
  void row(std::size_t r, const std::vector<double>& values) override {
    const auto i = static_cast<Eigen::Index>(r);
    for (std::size_t j = 0; j < layout_.column_a.size(); ++j) {
      const double a = values[layout_.column_a[j]];
      const double w = layout_.weight_b[j];
      surface_.height_m(i, static_cast<Eigen::Index>(j)) =
          w == 0.0 ? a : (1.0 - w) * a + w * values[layout_.column_b[j]];
    }
    for (std::size_t c = 0; c < h_.channels.size(); ++c) {
      const double v = values[c];
      if (std::isnan(v)) continue;
      switch (h_.channels[c].kind) {
        case Kind::heading:
          if (r > 0) {  // the first heading is not used: each one is the direction from the row before
            heading_min = std::min(heading_min, v);
            heading_max = std::max(heading_max, v);
          }
          break;
        case Kind::slope:
          max_abs_slope = std::max(max_abs_slope, std::abs(v));
          break;
        case Kind::banking:
          max_abs_banking = std::max(max_abs_banking, std::abs(v));
          break;
        default:
          break;
      }
    }
  }
  double heading_min = std::numeric_limits<double>::infinity();
  double heading_max = -std::numeric_limits<double>::infinity();
  double max_abs_slope = 0.0;
  double max_abs_banking = 0.0;

 private:
  const CrgHeader& h_;
  const LateralLayout& layout_;
  Surface& surface_;
};

double parameter_or(const CrgHeader& h, const char* key, double fallback) {
  const auto p = h.parameter(key);
  return p ? p->value : fallback;
}

std::vector<std::string> geometry_warnings(const CrgHeader& h, const SurfaceSink& sink,
                                           const Surface& surface) {
  std::vector<std::string> parts;
  // Curvature: a heading channel that varies, start and end headings that differ, or start and
  // end points closer than the length along the line.
  double heading_change = 0.0;
  if (sink.heading_max >= sink.heading_min) heading_change = sink.heading_max - sink.heading_min;
  const double phi_start = parameter_or(h, "REFERENCE_LINE_START_PHI", 0.0);
  const double phi_end = parameter_or(h, "REFERENCE_LINE_END_PHI", phi_start);
  heading_change = std::max(heading_change, std::abs(phi_end - phi_start));
  bool curved = heading_change > kStraightTolerance;
  if (h.parameter("REFERENCE_LINE_END_X") && h.parameter("REFERENCE_LINE_END_Y")) {
    const double chord = std::hypot(
        parameter_or(h, "REFERENCE_LINE_END_X", 0.0) - parameter_or(h, "REFERENCE_LINE_START_X", 0.0),
        parameter_or(h, "REFERENCE_LINE_END_Y", 0.0) - parameter_or(h, "REFERENCE_LINE_START_Y", 0.0));
    if (std::abs(chord - surface.length_m()) > 1e-6 * std::max(1.0, surface.length_m())) curved = true;
  }
  if (curved) {
    parts.push_back("curved (the heading changes by " + number_text(heading_change) +
                    " rad; the curvature is not applied)");
  }
  double slope = std::max({sink.max_abs_slope, std::abs(parameter_or(h, "REFERENCE_LINE_START_S", 0.0)),
                           std::abs(parameter_or(h, "REFERENCE_LINE_END_S", 0.0))});
  const double rise =
      parameter_or(h, "REFERENCE_LINE_END_Z", 0.0) - parameter_or(h, "REFERENCE_LINE_START_Z", 0.0);
  slope = std::max(slope, std::abs(rise) / surface.length_m());
  if (slope > 0.0) parts.push_back("sloped (up to " + number_text(slope) + " m/m; the grade is not added)");
  const double banking =
      std::max({sink.max_abs_banking, std::abs(parameter_or(h, "REFERENCE_LINE_START_B", 0.0)),
                std::abs(parameter_or(h, "REFERENCE_LINE_END_B", 0.0))});
  if (banking > 0.0)
    parts.push_back("banked (up to " + number_text(banking) + " m/m; the cross-fall is not added)");
  if (parts.empty()) return {};
  std::string text = "the reference line is ";
  for (std::size_t k = 0; k < parts.size(); ++k)
    text += (k == 0 ? "" : k + 1 == parts.size() ? " and " : ", ") + parts[k];
  text += ": the surface is mapped along the reference line (x = u - u_start, y = v), heights relative to it";
  return {text};
}

}  // namespace

CrgRoad read_crg(std::string_view bytes, const std::string& source) {
  const CrgHeader h = parse_crg_header(bytes, source);
  if (!h.has_road_section)
    throw DataError(source, h.end_line, "$ROAD_CRG", "the header has no $ROAD_CRG section");
  const auto increment = h.parameter("REFERENCE_LINE_INCREMENT");
  if (!increment) {
    throw DataError(source, h.end_line, "REFERENCE_LINE_INCREMENT",
                    "$ROAD_CRG must give REFERENCE_LINE_INCREMENT");
  }
  if (!(increment->value > 0.0)) {
    throw DataError(source, increment->line, "REFERENCE_LINE_INCREMENT",
                    "must be positive, found " + number_text(increment->value));
  }
  if (!h.has_definition_section) {
    throw DataError(source, h.end_line, "$KD_DEFINITION", "the header has no $KD_DEFINITION section");
  }
  const LateralLayout layout = lateral_layout(h, source);
  const std::size_t declared = declared_rows(h, increment->value, h.channels.size(), source);

  CrgRoad road;
  Surface& s = road.surface;
  s.name = source;
  s.dx_m = increment->value;
  s.y0_m = layout.y0_m;
  s.dy_m = layout.dy_m;
  SurfaceSink sink(h, layout, s);
  if (is_text(h.format))
    decode_text(bytes, h, declared, sink, source);
  else
    decode_binary(bytes, h, declared, sink, source);

  road.report.format = h.format;
  road.report.missing_cells = find_missing(s).count;
  road.report.warnings = geometry_warnings(h, sink, s);
  if (layout.resampled) {
    road.report.warnings.push_back("the long sections are unevenly spaced: resampled onto " +
                                   std::to_string(s.lines()) + " lines at " + number_text(s.dy_m) +
                                   " m, linearly between neighbours (as a wheel path reads them)");
  }
  for (const std::string& note : h.notes) road.report.warnings.push_back(note);
  return road;
}

CrgRoad read_crg_file(const std::string& path) {
  return read_crg(read_whole_file(path, "OpenCRG road file"), path);
}

}  // namespace ssrfleet::road
