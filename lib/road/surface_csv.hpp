// The road-surface CSV of docs/site-data.md:
//   x_m,<y0>,<y1>,...        header; each <y> a lateral position (m), evenly spaced, increasing
//   <x>,<h0>,<h1>,...        one row per longitudinal sample; heights in metres
// Lines starting with '#' (after optional blanks) and blank lines are skipped; cells may carry
// surrounding blanks; CRLF line ends are accepted. It holds the raw surface; envelopment is
// applied by the model.
//
// x may start anywhere: site positions are measured from the first row, so the surface is
// shifted to start at x = 0 (the original x0 is lost; sensors and heights are relative to it).
//
// Every defect is reported as ssrfleet::DataError(file, line, field, reason): a ragged row
// (field "columns"), a non-numeric, NaN or infinite cell (field: its column header), a header not
// starting with x_m (field "x_m"), a non-numeric lateral header (field: that header cell), fewer
// than 2 rows (field "x_m") or 2 lateral lines (field "header"), uneven or non-increasing spacing
// in x (field "x_m") or y (field: the offending header cell); spacing is even when each step is
// within 1e-6 (relative) of the first. Absurd sizes are refused before they are read whole
// (util/line_reader.hpp): a line longer than 1 MiB (field "line"), more than 100,000 columns
// (field "columns"), more than 1e8 heights (field "x_m").
#pragma once

#include <iosfwd>
#include <string>

#include "road/surface.hpp"

namespace ssrfleet::road {

// `source` names the input in messages and becomes surface.name.
Surface read_surface_csv(std::istream& in, const std::string& source);
// Missing or unreadable file -> ssrfleet::MissingInputError naming the path.
Surface read_surface_csv_file(const std::string& path);

// Shortest round-trip decimal form of every number (std::to_chars), so write -> read gives the
// same doubles bit for bit (heights, dx, y0 and dy). x_i is written as i * dx, y_j as y0 + j dy.
// The format has no missing value: a missing (NaN) or infinite height throws std::invalid_argument
// before anything is written, rather than write a file that does not read back.
void write_surface_csv(const Surface& surface, std::ostream& out);
// Atomic: writes `path.tmp.<pid>` and renames it onto `path`, so a failure never leaves a
// partial file. Failure -> ssrfleet::IoError naming the path.
void write_surface_csv_file(const Surface& surface, const std::string& path);

}  // namespace ssrfleet::road
