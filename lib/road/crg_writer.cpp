#include "road/crg_writer.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <ostream>
#include <stdexcept>

#include "road/road_file.hpp"

namespace ssrfleet::road {

namespace {

std::string formatted(const char* format, int precision, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, precision, value);
  return buffer;
}

std::string right_aligned(const std::string& text, std::size_t width) {
  return text.size() >= width ? text : std::string(width - text.size(), ' ') + text;
}

void append_big_endian(std::string& out, double value, bool dbl) {
  if (dbl) {
    const auto u = std::bit_cast<std::uint64_t>(value);
    for (int shift = 56; shift >= 0; shift -= 8) out += static_cast<char>((u >> shift) & 0xff);
  } else {
    const auto u = std::bit_cast<std::uint32_t>(static_cast<float>(value));
    for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((u >> shift) & 0xff);
  }
}

// A header line, cut to the 72 characters a reader honours.
std::string header_line(const std::string& text) { return text.substr(0, crg_header_line_chars) + "\n"; }

}  // namespace

std::string crg_text_field(double value, CrgDataFormat format) {
  const std::size_t width = value_size(format);
  if (std::isnan(value)) return right_aligned("*missing*", width);
  if (format == CrgDataFormat::lrfi) {
    const std::string fixed = formatted("%.*f", 7, value);
    if (fixed.size() <= width) return right_aligned(fixed, width);
  }
  for (int precision = format == CrgDataFormat::ldfi ? 13 : 3; precision >= 0; --precision) {
    const std::string text = formatted("%.*e", precision, value);
    if (text.size() <= width) return right_aligned(text, width);
  }
  throw std::invalid_argument("crg_text_field: " + shortest_decimal(value) + " does not fit a field");
}

void write_crg(const Surface& surface, std::ostream& out, CrgDataFormat format) {
  if ((surface.height_m.isInf()).any()) {
    throw std::invalid_argument("write_crg: the surface '" + surface.name + "' holds an infinite height");
  }
  const Eigen::Index rows = surface.samples(), lines = surface.lines();
  std::string text;
  text += header_line("$CT");
  text += header_line("ssrfleet road surface " + surface.name);
  text += header_line("Straight level reference line along x; long sections numbered from");
  text += header_line("the right edge, v = y; heights in metres relative to the line.");
  text += header_line("$");
  text += header_line("$ROAD_CRG");
  text += header_line("REFERENCE_LINE_START_U   = 0");
  text += header_line("REFERENCE_LINE_END_U     = " +
                      shortest_decimal(surface.dx_m * static_cast<double>(rows - 1)));
  text += header_line("REFERENCE_LINE_INCREMENT = " + shortest_decimal(surface.dx_m));
  text += header_line("LONG_SECTION_V_RIGHT     = " + shortest_decimal(surface.y0_m));
  text += header_line("LONG_SECTION_V_LEFT      = " + shortest_decimal(surface.y_max_m()));
  text += header_line("LONG_SECTION_V_INCREMENT = " + shortest_decimal(surface.dy_m));
  text += header_line("$");
  text += header_line("$KD_DEFINITION");
  text += header_line("#:" + crg_format_name(format));
  for (Eigen::Index j = 0; j < lines; ++j) {
    text += header_line("D:long section " + std::to_string(j + 1) +
                        ",m ! v = " + shortest_decimal(surface.lateral_m(j)));
  }
  text += header_line("$");
  text += std::string(crg_header_line_chars, '$') + "\n";
  out << text;

  if (is_text(format)) {
    const std::size_t per_line = fields_per_line(format);
    for (Eigen::Index i = 0; i < rows; ++i) {
      text.clear();
      for (Eigen::Index j = 0; j < lines; ++j) {
        text += crg_text_field(surface.height_m(i, j), format);
        if (static_cast<std::size_t>(j + 1) % per_line == 0 || j + 1 == lines) text += '\n';
      }
      out << text;
    }
    return;
  }
  const bool dbl = is_double(format);
  std::size_t written = 0;
  for (Eigen::Index i = 0; i < rows; ++i) {
    text.clear();
    for (Eigen::Index j = 0; j < lines; ++j) append_big_endian(text, surface.height_m(i, j), dbl);
    written += text.size();
    out << text;
  }
  // Pad the last 80-byte record with NaNs.
  text.clear();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  while ((written + text.size()) % crg_record_bytes != 0) append_big_endian(text, nan, dbl);
  out << text;
}

void write_crg_file(const Surface& surface, const std::string& path, CrgDataFormat format) {
  write_file_atomically(path, "OpenCRG road file",
                        [&](std::ostream& out) { write_crg(surface, out, format); });
}

}  // namespace ssrfleet::road
