// Reading an ASAM OpenCRG file (crg_format.hpp) into an ssrfleet surface: the grid is taken
// along the reference line, x = u - u_start (the first cross section at x = 0) and y = v (positive
// to the left of travel), heights in metres relative to the reference line. All four data types
// (LRFI, LDFI, KRBI, KDBI) are read.
//
// The grid. dx is REFERENCE_LINE_INCREMENT. The long sections are either numbered ("long
// section N,m": v = LONG_SECTION_V_RIGHT + (N-1) LONG_SECTION_V_INCREMENT, from whichever two of
// V_RIGHT, V_LEFT, V_INCREMENT are given, centred on the reference line when only the increment
// is) or placed ("long section at v = X,m", in any order). Unevenly placed long sections that all
// lie on a regular grid of the smallest spacing are resampled onto it, linearly between
// neighbours, which is exactly how a wheel path reads them (wheel_path.hpp), with a warning;
// otherwise they are an error. The rows are the payload's; REFERENCE_LINE_END_U, when given, must
// agree with them.
//
// What is not applied, with a warning: a curved reference line (heading channel or start/end
// headings or positions that differ), slope (channel, start/end slope or elevation) and banking
// (channel or start/end values), and $ROAD_CRG_MODS modifiers. The surface is then the road as a
// vehicle following the reference line sees it, without grade, cross-fall or bends.
//
// Missing cells (`*missing*` fields, NaNs) become NaN heights (missing_cells.hpp) and are counted;
// the binary payload's trailing NaN padding is not a cell.
//
// Bad input is ssrfleet::DataError naming the file and the line (text) or byte offset (binary):
// besides the header's defects (crg_header.hpp), a missing $ROAD_CRG, REFERENCE_LINE_INCREMENT or
// $KD_DEFINITION; fewer than 2 long sections; numbered and placed long sections mixed, numbers
// not 1..n, or n disagreeing with V_RIGHT..V_LEFT at V_INCREMENT; a truncated payload (a partial
// row, or fewer rows than REFERENCE_LINE_END_U declares); more data than declared; a text field
// that is blank or not a number (line and column named); and sizes beyond 1e8 cells, refused
// before anything is allocated.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "road/crg_format.hpp"
#include "road/surface.hpp"

namespace ssrfleet::road {

struct CrgReadReport {
  CrgDataFormat format = CrgDataFormat::krbi;
  Eigen::Index missing_cells = 0;
  std::vector<std::string> warnings;  // what the surface leaves out, in words a user can act on
};

struct CrgRoad {
  Surface surface;
  CrgReadReport report;
};

// `source` names the input in messages and becomes surface.name.
CrgRoad read_crg(std::string_view bytes, const std::string& source);
// Missing or unreadable file -> ssrfleet::MissingInputError naming the path.
CrgRoad read_crg_file(const std::string& path);

}  // namespace ssrfleet::road
