// Where a surface's missing cells are, in terms a user can act on: which lateral lines hold them
// and over which x range, and which lateral ranges are clear (a wheel path there reads measured
// road only). Consecutive lines with the same pattern (cell count, number of separate holes,
// first and last x) are one group, so a hole along an edge or across the road is one entry.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "road/surface.hpp"

namespace ssrfleet::road {

// Lines [line_begin, line_end), each with `cells_per_line` missing cells in `holes_per_line`
// separate runs along x, the first in row first_row and the last in row last_row.
struct MissingLineGroup {
  Eigen::Index line_begin = 0;
  Eigen::Index line_end = 0;
  Eigen::Index cells_per_line = 0;
  Eigen::Index holes_per_line = 0;
  Eigen::Index first_row = 0;
  Eigen::Index last_row = 0;
};

struct MissingMap {
  Eigen::Index cells = 0;
  Eigen::Index lines_with_missing = 0;
  Eigen::Index first_row = -1;  // over all lines; -1 when nothing is missing
  Eigen::Index last_row = -1;
  std::vector<MissingLineGroup> groups;  // by lateral position, at most max_groups
  std::size_t groups_left_out = 0;       // groups past max_groups (counted, not listed)
  std::vector<std::pair<Eigen::Index, Eigen::Index>> clear_lines;  // runs [first, last] of complete lines
};

MissingMap map_missing(const Surface& surface, std::size_t max_groups = 1000);

// Positions of the grid the map was made on: x = row dx, y = y0 + line dy.
struct GridPositions {
  double dx_m = 0.0;
  double y0_m = 0.0;
  double dy_m = 0.0;
  double x(Eigen::Index row) const { return dx_m * static_cast<double>(row); }
  double y(Eigen::Index line) const { return y0_m + dy_m * static_cast<double>(line); }
};

// Text lines for a report, each starting with `indent`: the groups (at most max_listed, then how
// many more) and the clear lateral ranges (at most max_listed). Positions to 6 significant digits.
std::string describe_map(const MissingMap& map, const GridPositions& grid, const std::string& indent,
                         std::size_t max_listed = 12);

// {"cells", "lines_with_missing", "x_from_m", "x_to_m" (when any), "groups": [{"first_line",
// "lines", "y_from_m", "y_to_m", "cells_per_line", "holes_per_line", "x_from_m", "x_to_m"}],
// "groups_left_out", "clear_of_holes": [{"y_from_m", "y_to_m"}]}.
nlohmann::json to_json(const MissingMap& map, const GridPositions& grid);

}  // namespace ssrfleet::road
