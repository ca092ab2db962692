#include "road/missing_map.hpp"

#include <algorithm>
#include <sstream>

#include "road/missing_cells.hpp"

namespace ssrfleet::road {

namespace {

MissingLineGroup line_pattern(const Surface& surface, Eigen::Index j) {
  MissingLineGroup g;
  g.line_begin = j;
  g.line_end = j + 1;
  g.first_row = -1;
  g.last_row = -1;
  const double* line = surface.line(j);
  bool in_hole = false;
  for (Eigen::Index i = 0; i < surface.samples(); ++i) {
    const bool missing = is_missing(line[i]);
    if (missing) {
      ++g.cells_per_line;
      if (!in_hole) ++g.holes_per_line;
      if (g.first_row < 0) g.first_row = i;
      g.last_row = i;
    }
    in_hole = missing;
  }
  return g;
}

bool same_pattern(const MissingLineGroup& a, const MissingLineGroup& b) {
  return a.cells_per_line == b.cells_per_line && a.holes_per_line == b.holes_per_line &&
         a.first_row == b.first_row && a.last_row == b.last_row;
}

}  // namespace

MissingMap map_missing(const Surface& surface, std::size_t max_groups) {
  MissingMap map;
  MissingLineGroup open;  // the group being extended; cells_per_line 0 when none
  const auto close = [&] {
    if (open.cells_per_line == 0) return;
    if (map.groups.size() < max_groups)
      map.groups.push_back(open);
    else
      ++map.groups_left_out;
    open = MissingLineGroup{};
  };
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    const MissingLineGroup g = line_pattern(surface, j);
    if (g.cells_per_line == 0) {
      close();
      if (!map.clear_lines.empty() && map.clear_lines.back().second == j - 1)
        map.clear_lines.back().second = j;
      else
        map.clear_lines.emplace_back(j, j);
      continue;
    }
    map.cells += g.cells_per_line;
    ++map.lines_with_missing;
    map.first_row = map.first_row < 0 ? g.first_row : std::min(map.first_row, g.first_row);
    map.last_row = std::max(map.last_row, g.last_row);
    if (open.cells_per_line > 0 && same_pattern(open, g)) {
      open.line_end = j + 1;
    } else {
      close();
      open = g;
    }
  }
  close();
  return map;
}

std::string describe_map(const MissingMap& map, const GridPositions& grid, const std::string& indent,
                         std::size_t max_listed) {
  std::ostringstream os;
  os.precision(6);
  const auto x = [&](Eigen::Index row) { return grid.x(row); };
  std::size_t listed = 0;
  for (const MissingLineGroup& g : map.groups) {
    if (listed == max_listed) break;
    ++listed;
    const Eigen::Index lines = g.line_end - g.line_begin;
    os << indent << "y = " << grid.y(g.line_begin);
    if (lines > 1)
      os << " .. " << grid.y(g.line_end - 1) << " m (" << lines << " lines): ";
    else
      os << " m: ";
    os << g.cells_per_line << " cell" << (g.cells_per_line == 1 ? "" : "s");
    if (g.holes_per_line > 1) os << " in " << g.holes_per_line << " holes";
    if (lines > 1) os << " each";
    if (g.first_row == g.last_row)
      os << " at x = " << x(g.first_row) << " m\n";
    else
      os << ", x = " << x(g.first_row) << " .. " << x(g.last_row) << " m\n";
  }
  const std::size_t more = map.groups.size() - listed + map.groups_left_out;
  if (more > 0)
    os << indent << "... and " << more << " more group" << (more == 1 ? "" : "s") << " of lines\n";
  os << indent << "clear of holes: ";
  if (map.clear_lines.empty()) os << "no line (every line has a missing cell)\n";
  const std::size_t ranges = std::min(map.clear_lines.size(), max_listed);
  for (std::size_t k = 0; k < ranges; ++k) {
    const auto [first, last] = map.clear_lines[k];
    os << (k == 0 ? "y = " : ", ") << grid.y(first);
    if (last > first) os << " .. " << grid.y(last);
  }
  if (ranges > 0) os << " m";
  if (map.clear_lines.size() > ranges) os << " and " << map.clear_lines.size() - ranges << " more ranges";
  if (ranges > 0) os << "\n";
  return os.str();
}

nlohmann::json to_json(const MissingMap& map, const GridPositions& grid) {
  nlohmann::json groups = nlohmann::json::array();
  for (const MissingLineGroup& g : map.groups) {
    groups.push_back({{"first_line", g.line_begin},
                      {"lines", g.line_end - g.line_begin},
                      {"y_from_m", grid.y(g.line_begin)},
                      {"y_to_m", grid.y(g.line_end - 1)},
                      {"cells_per_line", g.cells_per_line},
                      {"holes_per_line", g.holes_per_line},
                      {"x_from_m", grid.x(g.first_row)},
                      {"x_to_m", grid.x(g.last_row)}});
  }
  nlohmann::json clear = nlohmann::json::array();
  for (const auto& [first, last] : map.clear_lines)
    clear.push_back({{"y_from_m", grid.y(first)}, {"y_to_m", grid.y(last)}});
  nlohmann::json j = {{"cells", map.cells},
                      {"lines_with_missing", map.lines_with_missing},
                      {"groups", groups},
                      {"groups_left_out", map.groups_left_out},
                      {"clear_of_holes", clear}};
  if (map.cells > 0) {
    j["x_from_m"] = grid.x(map.first_row);
    j["x_to_m"] = grid.x(map.last_row);
  }
  return j;
}

}  // namespace ssrfleet::road
