// Missing cells of a road surface. A measured surface (an OpenCRG file's `*missing*` cells or
// NaNs) may have holes, usually at its lateral edges where the scanner lost the road; a Surface
// holds them as NaN heights. Nothing may read through a hole: a truck's wheel path or sensor
// lane that crosses one is an error, and an IRI across one is reported as unavailable, never as
// a silently wrong number. Holes elsewhere are allowed and reported (missing_map.hpp maps them).
#pragma once

#include <cmath>
#include <string>

#include <Eigen/Core>

#include "road/surface.hpp"

namespace ssrfleet::road {

// Missing cells in the block rows [row_begin, row_end) x lines [line_begin, line_end), the first
// of them in row-major order (by x, then by y), or row = line = -1 when there is none, and the
// last row that holds one (-1 when none).
struct MissingCells {
  Eigen::Index count = 0;
  Eigen::Index first_row = -1;
  Eigen::Index first_line = -1;
  Eigen::Index last_row = -1;
};

inline bool is_missing(double height_m) { return std::isnan(height_m); }

MissingCells find_missing(const Surface& surface);
MissingCells find_missing(const Surface& surface, Eigen::Index row_begin, Eigen::Index row_end,
                          Eigen::Index line_begin, Eigen::Index line_end);

// The first row (sample along x) that holds a missing cell in any line; samples() if none.
Eigen::Index first_row_with_missing(const Surface& surface);

// "12 missing cells, the first at x = 40.25 m, y = 1.5 m" (for messages); "no missing cells".
std::string describe(const MissingCells& missing, const Surface& surface);
// "12 missing cells between x = 40.25 and 40.8 m" ("1 missing cell at x = 40.25 m"); "no missing
// cells". Positions to 6 significant digits.
std::string describe_span(const MissingCells& missing, const Surface& surface);

}  // namespace ssrfleet::road
