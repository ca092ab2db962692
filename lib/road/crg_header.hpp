// The clear-text header of an OpenCRG file (crg_format.hpp), parsed into what the reader needs:
// the $ROAD_CRG parameters, the data type and channels of $KD_DEFINITION, and where the payload
// starts. It interprets nothing (no grid is built here); crg_reader.cpp does.
//
// Defects are ssrfleet::DataError naming the file, the line and the field: a section given twice,
// a parameter given twice or not a finite number, a $ROAD_CRG line that is not KEY = value, an
// unknown data type on a "#:" line (OpenCRG defines LRFI, LDFI, KRBI, KDBI), a channel definition
// without "name,unit", a long section whose unit is not m or whose position or number does not
// parse, a reference-line channel in the wrong unit, an unrecognised $KD_DEFINITION line, a
// $ROAD_CRG_FILE section (references to other files are not read), and a header without its
// closing "$$" line.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "road/crg_format.hpp"

namespace ssrfleet::road {

struct CrgChannel {
  enum class Kind { long_section, heading, banking, slope, other };
  Kind kind = Kind::other;
  bool at_position = false;  // "long section at v = X,m" (else "long section N,m")
  double v_m = 0.0;          // X
  long number = 0;           // N, 1-based from the right edge
  std::string definition;    // the "D:" text, for messages
  std::size_t line = 0;
};

struct CrgParameter {
  double value = 0.0;
  std::size_t line = 0;
};

struct CrgHeader {
  std::string comment;                       // the $CT text
  std::map<std::string, CrgParameter> road;  // $ROAD_CRG, keys in upper case
  bool has_road_section = false;
  bool has_definition_section = false;
  CrgDataFormat format = CrgDataFormat::krbi;  // the spec's default when no "#:" line is given
  std::size_t format_line = 0;                 // 0: not declared
  std::vector<CrgChannel> channels;            // in payload column order
  std::vector<std::string> notes;              // what was read past (sections, parameters, channels)
  std::size_t definition_line = 0;             // the $KD_DEFINITION line
  std::size_t end_line = 0;                    // the "$$" line
  std::size_t payload_offset = 0;              // first payload byte

  std::optional<CrgParameter> parameter(const std::string& key) const;
};

CrgHeader parse_crg_header(std::string_view bytes, const std::string& source);

}  // namespace ssrfleet::road
