// The part of a surface with holes that its roughness is measured on: a PSD needs unbroken lines,
// and a hole would leak into every frequency, so the fit reads
//  - every line with no missing cell, over the whole length, when there is one; otherwise
//  - the longest stretch of rows over which some line is unbroken (the first such stretch on a
//    tie), and every line unbroken over it: a gap across the whole width leaves the longest piece.
// An empty part (no lines) when every cell is missing.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "road/surface.hpp"

namespace ssrfleet::road {

struct MeasuredPart {
  Eigen::Index row_begin = 0;  // rows [row_begin, row_end)
  Eigen::Index row_end = 0;
  std::vector<Eigen::Index> lines;  // increasing
  bool whole_lines = false;         // the lines are unbroken over the whole length
};

MeasuredPart measured_part(const Surface& surface);

// The part as a surface of its own (same dx, dy; x restarts at 0; y0 kept, lines may be uneven:
// only for along-travel statistics such as the PSD).
Surface extract(const Surface& surface, const MeasuredPart& part);

}  // namespace ssrfleet::road
