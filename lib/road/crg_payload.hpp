// The payload of an OpenCRG file (docs/site-data.md): the rows of channel values after the
// header, in the binary (big-endian float or double) or the fixed-width text formats, each row
// handed to a sink as it is decoded. Every error names the source and the byte offset or line.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "road/crg_header.hpp"

namespace ssrfleet::road {

// More values than this in one payload are refused: 800 MB of heights, far beyond any measured
// road (a corrupt header, not a road).
inline constexpr double kMaxCrgCells = 1e8;

// Decoded payload rows, one callback per row with its channel values.
class RowSink {
 public:
  virtual ~RowSink() = default;
  virtual void reserve(std::size_t rows) = 0;
  virtual void row(std::size_t r, const std::vector<double>& values) = 0;
};

// The payload of `bytes` after h.payload_offset, in h.format; `declared` rows if the header
// declares them (0: as many as the payload holds). DataError naming `source` on a bad payload.
void decode_binary(std::string_view bytes, const CrgHeader& h, std::size_t declared, RowSink& sink,
                   const std::string& source);
void decode_text(std::string_view bytes, const CrgHeader& h, std::size_t declared, RowSink& sink,
                 const std::string& source);

}  // namespace ssrfleet::road
