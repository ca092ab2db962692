#include "road/surface_csv.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <istream>
#include <stdexcept>
#include <ostream>
#include <string_view>
#include <system_error>
#include <vector>

#include "road/road_file.hpp"
#include "util/errors.hpp"
#include "util/line_reader.hpp"

namespace ssrfleet::road {

namespace {

constexpr double kSpacingTolerance = 1e-6;  // relative, on each step against the first

std::string_view trim(std::string_view s) { return trim_blanks(s); }

std::vector<std::string_view> split_cells(std::string_view line) {
  std::vector<std::string_view> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) return cells;
    start = comma + 1;
  }
}

// Parses the whole cell as a finite double, or explains why not.
bool parse_finite(std::string_view cell, double& value, std::string& why) {
  const char* end = cell.data() + cell.size();
  const auto [ptr, ec] = std::from_chars(cell.data(), end, value);
  if (cell.empty() || ec != std::errc() || ptr != end) {
    why.assign(1, '\'').append(cell).append("' is not a number");
    return false;
  }
  if (!std::isfinite(value)) {
    why.assign(1, '\'').append(cell).append("' is not finite");
    return false;
  }
  return true;
}

// The spacing that regenerates every value exactly as v0 + i * s when the values were written
// by write_surface_csv (so dx and dy round-trip bit for bit); otherwise the mean step.
double best_spacing(const std::vector<double>& v) {
  const double mean_step = (v.back() - v.front()) / static_cast<double>(v.size() - 1);
  const double candidates[] = {v[1] - v[0], mean_step, std::nextafter(mean_step, 0.0),
                               std::nextafter(mean_step, 2.0 * mean_step + 1.0)};
  for (const double s : candidates) {
    bool exact = true;
    for (std::size_t i = 0; i < v.size() && exact; ++i) exact = (v[0] + static_cast<double>(i) * s == v[i]);
    if (exact) return s;
  }
  return mean_step;
}

void append_number(std::string& out, double value) {
  char buffer[32];
  const auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, ptr);
}

}  // namespace

Surface read_surface_csv(std::istream& in, const std::string& source) {
  std::string text;
  std::size_t line_no = 0;
  std::size_t header_line = 0;
  std::vector<std::string> header_cells;
  std::vector<double> lateral_m;
  std::vector<double> x_m;
  std::vector<std::size_t> x_line;
  std::vector<double> heights;  // row-major while reading

  for (;;) {
    const LineRead got = read_bounded_line(in, text, kMaxCsvLineBytes);
    if (got == LineRead::end) break;
    ++line_no;
    if (got == LineRead::too_long) {
      throw DataError(source, line_no, "line",
                      "the line is longer than " + std::to_string(kMaxCsvLineBytes) +
                          " bytes (1 MiB), the most a road CSV line may hold; not read further");
    }
    const std::string_view line = trim(text);
    if (line.empty() || line.front() == '#') continue;
    if (static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) >= kMaxCsvColumns) {
      throw DataError(source, line_no, "columns",
                      "more than " + std::to_string(kMaxCsvColumns) + " columns, the most a road CSV line may hold");
    }
    if (!header_cells.empty() &&
        static_cast<double>(heights.size() + header_cells.size() - 1) > kMaxSurfaceCells) {
      throw DataError(source, line_no, "x_m", "the surface holds more than 1e8 heights, the most ssrfleet reads");
    }
    const auto cells = split_cells(line);
    if (header_cells.empty()) {
      header_line = line_no;
      if (cells[0] != "x_m") {
        throw DataError(source, line_no, "x_m",
                        "the header must start with x_m, found '" + std::string(cells[0]) + "'");
      }
      for (std::size_t c = 1; c < cells.size(); ++c) {
        double y = 0.0;
        std::string why;
        if (!parse_finite(cells[c], y, why)) {
          throw DataError(source, line_no, std::string(cells[c]), "lateral position (m) " + why);
        }
        if (!lateral_m.empty()) {
          const double step = y - lateral_m.back();
          if (!(step > 0.0)) {
            throw DataError(source, line_no, std::string(cells[c]), "lateral positions must increase");
          }
          if (lateral_m.size() >= 2) {
            const double first = lateral_m[1] - lateral_m[0];
            if (std::abs(step - first) > kSpacingTolerance * first) {
              throw DataError(source, line_no, std::string(cells[c]),
                              "uneven lateral spacing: step " + std::to_string(step) + " m, first step " +
                                  std::to_string(first) + " m");
            }
          }
        }
        lateral_m.push_back(y);
      }
      if (lateral_m.size() < 2) {
        throw DataError(source, line_no, "header",
                        "need at least 2 lateral lines, found " + std::to_string(lateral_m.size()));
      }
      header_cells.assign(cells.begin(), cells.end());
      continue;
    }
    if (cells.size() != header_cells.size()) {
      throw DataError(source, line_no, "columns",
                      "row has " + std::to_string(cells.size()) + " columns, the header has " +
                          std::to_string(header_cells.size()));
    }
    for (std::size_t c = 0; c < cells.size(); ++c) {
      double v = 0.0;
      std::string why;
      if (!parse_finite(cells[c], v, why)) throw DataError(source, line_no, header_cells[c], why);
      if (c == 0) {
        if (!x_m.empty()) {
          const double step = v - x_m.back();
          if (!(step > 0.0)) throw DataError(source, line_no, "x_m", "x must increase from row to row");
          if (x_m.size() >= 2) {
            const double first = x_m[1] - x_m[0];
            if (std::abs(step - first) > kSpacingTolerance * first) {
              throw DataError(source, line_no, "x_m",
                              "uneven spacing in x: step " + std::to_string(step) + " m, first step " +
                                  std::to_string(first) + " m");
            }
          }
        }
        x_m.push_back(v);
        x_line.push_back(line_no);
      } else {
        heights.push_back(v);
      }
    }
  }
  if (in.bad()) throw DataError(source, line_no, "x_m", "read error");
  if (header_cells.empty()) throw DataError(source, line_no, "x_m", "no header line (x_m,<y0>,<y1>,...)");
  if (x_m.size() < 2) {
    throw DataError(source, x_m.empty() ? header_line : x_line.back(), "x_m",
                    "need at least 2 rows, found " + std::to_string(x_m.size()));
  }

  // Shift x to start at 0 (site positions are measured from the first row).
  std::vector<double> x_shifted(x_m.size());
  for (std::size_t i = 0; i < x_m.size(); ++i) x_shifted[i] = x_m[i] - x_m[0];

  Surface surface;
  surface.name = source;
  surface.dx_m = best_spacing(x_shifted);
  surface.y0_m = lateral_m.front();
  surface.dy_m = best_spacing(lateral_m);
  const auto rows = static_cast<Eigen::Index>(x_m.size());
  const auto cols = static_cast<Eigen::Index>(lateral_m.size());
  surface.height_m = Eigen::Map<const Eigen::Array<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      heights.data(), rows, cols);
  return surface;
}

Surface read_surface_csv_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw MissingInputError("road surface file '" + path + "' does not exist or is not a regular file");
  }
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open road surface file '" + path + "'");
  return read_surface_csv(in, path);
}

void write_surface_csv(const Surface& surface, std::ostream& out) {
  if (!surface.height_m.allFinite()) {
    throw std::invalid_argument("write_surface_csv: the surface '" + surface.name +
                                "' has a missing or non-finite height, which a road CSV cannot hold");
  }
  std::string buffer;
  buffer.reserve(static_cast<std::size_t>(surface.lines()) * 24 + 16);
  buffer = "# ssrfleet road surface";
  if (!surface.name.empty()) buffer += " '" + surface.name + "'";
  buffer += ": x_m then heights (m) at each lateral position (m)\nx_m";
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    buffer += ',';
    append_number(buffer, surface.y0_m + static_cast<double>(j) * surface.dy_m);
  }
  buffer += '\n';
  out << buffer;
  for (Eigen::Index i = 0; i < surface.samples(); ++i) {
    buffer.clear();
    append_number(buffer, static_cast<double>(i) * surface.dx_m);
    for (Eigen::Index j = 0; j < surface.lines(); ++j) {
      buffer += ',';
      append_number(buffer, surface.height_m(i, j));
    }
    buffer += '\n';
    out << buffer;
  }
}

void write_surface_csv_file(const Surface& surface, const std::string& path) {
  write_file_atomically(path, "road surface file", [&](std::ostream& out) { write_surface_csv(surface, out); });
}

}  // namespace ssrfleet::road
