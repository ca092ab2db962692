#include "road/missing_cells.hpp"

#include <algorithm>
#include <sstream>

namespace ssrfleet::road {

MissingCells find_missing(const Surface& surface) {
  return find_missing(surface, 0, surface.samples(), 0, surface.lines());
}

MissingCells find_missing(const Surface& surface, Eigen::Index row_begin, Eigen::Index row_end,
                          Eigen::Index line_begin, Eigen::Index line_end) {
  row_begin = std::max<Eigen::Index>(0, row_begin);
  line_begin = std::max<Eigen::Index>(0, line_begin);
  row_end = std::min(row_end, surface.samples());
  line_end = std::min(line_end, surface.lines());
  MissingCells m;
  for (Eigen::Index j = line_begin; j < line_end; ++j) {
    const double* line = surface.line(j);
    for (Eigen::Index i = row_begin; i < row_end; ++i) {
      if (!is_missing(line[i])) continue;
      ++m.count;
      m.last_row = std::max(m.last_row, i);
      if (m.first_row < 0 || i < m.first_row || (i == m.first_row && j < m.first_line)) {
        m.first_row = i;
        m.first_line = j;
      }
    }
  }
  return m;
}

Eigen::Index first_row_with_missing(const Surface& surface) {
  Eigen::Index first = surface.samples();
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    const double* line = surface.line(j);
    for (Eigen::Index i = 0; i < first; ++i) {
      if (is_missing(line[i])) {
        first = i;
        break;
      }
    }
  }
  return first;
}

std::string describe(const MissingCells& missing, const Surface& surface) {
  if (missing.count == 0) return "no missing cells";
  std::ostringstream os;
  os << missing.count << " missing cell" << (missing.count == 1 ? "" : "s")
     << ", the first at x = " << surface.dx_m * static_cast<double>(missing.first_row)
     << " m, y = " << surface.lateral_m(missing.first_line) << " m";
  return os.str();
}

std::string describe_span(const MissingCells& missing, const Surface& surface) {
  if (missing.count == 0) return "no missing cells";
  std::ostringstream os;
  os.precision(6);
  const double from_m = surface.dx_m * static_cast<double>(missing.first_row);
  const double to_m = surface.dx_m * static_cast<double>(missing.last_row);
  os << missing.count << " missing cell" << (missing.count == 1 ? "" : "s");
  if (missing.first_row == missing.last_row) os << " at x = " << from_m << " m";
  else os << " between x = " << from_m << " and " << to_m << " m";
  return os.str();
}

}  // namespace ssrfleet::road
