// Writing any ssrfleet surface as an ASAM OpenCRG file (crg_format.hpp): a straight, level
// reference line along x (u = x, REFERENCE_LINE_START_U = 0), numbered long sections from the
// right edge (v = y: LONG_SECTION_V_RIGHT = y0, LONG_SECTION_V_INCREMENT = dy), heights in metres,
// missing cells (NaN) as NaN in binary and `*missing*` in text. Header numbers are the shortest
// decimals that read back to the same doubles, so dx, y0 and dy survive a round trip bit for bit.
//
// Precision of the payload, by data type:
//   KDBI (the default)  float64: every height read back bit for bit.
//   KRBI                float32: each height rounded to the nearest float.
//   LDFI                "%20.13e": 14 significant digits (relative error <= 5e-14).
//   LRFI                "%10.7f" when it fits in 10 characters (-10 m < h < 100 m: 1e-7 m, i.e.
//                        within 5e-8 m), else scientific with as many digits as fit.
#pragma once

#include <iosfwd>
#include <string>

#include "road/crg_format.hpp"
#include "road/surface.hpp"

namespace ssrfleet::road {

// Throws std::invalid_argument for an infinite height (a missing one, NaN, is written as such).
void write_crg(const Surface& surface, std::ostream& out, CrgDataFormat format = CrgDataFormat::kdbi);
// Atomic (temporary file, then rename); failure -> ssrfleet::IoError naming the path.
void write_crg_file(const Surface& surface, const std::string& path,
                    CrgDataFormat format = CrgDataFormat::kdbi);

// One text field exactly value_size(format) characters wide, by the rule above (for LRFI and LDFI).
std::string crg_text_field(double value, CrgDataFormat format);

}  // namespace ssrfleet::road
