#include "road/measured_part.hpp"

#include "road/missing_cells.hpp"

namespace ssrfleet::road {

namespace {

bool unbroken(const Surface& surface, Eigen::Index line, Eigen::Index row_begin, Eigen::Index row_end) {
  const double* h = surface.line(line);
  for (Eigen::Index i = row_begin; i < row_end; ++i) {
    if (is_missing(h[i])) return false;
  }
  return true;
}

}  // namespace

MeasuredPart measured_part(const Surface& surface) {
  MeasuredPart part;
  part.row_end = surface.samples();
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    if (unbroken(surface, j, 0, surface.samples())) part.lines.push_back(j);
  }
  part.whole_lines = !part.lines.empty();
  if (part.whole_lines) return part;

  // No line is whole: the longest unbroken run of any line.
  Eigen::Index best_begin = 0, best_end = 0;
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    const double* h = surface.line(j);
    Eigen::Index begin = 0;
    for (Eigen::Index i = 0; i <= surface.samples(); ++i) {
      if (i < surface.samples() && !is_missing(h[i])) continue;
      if (i - begin > best_end - best_begin || (i - begin == best_end - best_begin && begin < best_begin)) {
        best_begin = begin;
        best_end = i;
      }
      begin = i + 1;
    }
  }
  part.row_begin = best_begin;
  part.row_end = best_end;
  if (best_end == best_begin) return part;
  for (Eigen::Index j = 0; j < surface.lines(); ++j) {
    if (unbroken(surface, j, best_begin, best_end)) part.lines.push_back(j);
  }
  return part;
}

Surface extract(const Surface& surface, const MeasuredPart& part) {
  Surface s;
  s.name = surface.name;
  s.dx_m = surface.dx_m;
  s.dy_m = surface.dy_m;
  s.y0_m = surface.y0_m;
  s.height_m.resize(part.row_end - part.row_begin, static_cast<Eigen::Index>(part.lines.size()));
  for (std::size_t k = 0; k < part.lines.size(); ++k) {
    s.height_m.col(static_cast<Eigen::Index>(k)) =
        surface.height_m.col(part.lines[k]).segment(part.row_begin, part.row_end - part.row_begin);
  }
  return s;
}

}  // namespace ssrfleet::road
