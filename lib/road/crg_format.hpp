// The vocabulary of ASAM OpenCRG files that the reader (crg_reader.hpp) and the writer
// (crg_writer.hpp) share. An OpenCRG file is a clear-text header of sections ($CT comment,
// $ROAD_CRG reference-line parameters, $KD_DEFINITION data format and channels, optional
// $ROAD_CRG_OPTS / _MODS / _MPRO / _FILE), ended by a line starting "$$", then the payload: one
// row per cross section (u = const), one column per channel, in one of four data types:
//   LRFI  text,   real:   10-character fields, 8 to a line (80 characters)
//   LDFI  text,   double: 20-character fields, 4 to a line
//   KRBI  binary, real:   IEEE 754 big-endian float32, rows back to back
//   KDBI  binary, double: IEEE 754 big-endian float64, rows back to back
// Text rows start on a new line and wrap onto as many lines as they need; binary data fill
// 80-byte records and the last record is padded with NaNs. A missing value is a field starting
// with '*' (`*missing*`) in text and a NaN in binary. Header lines count up to 72 characters
// (the rest is ignored), '*' in column 1 comments a line, '!' starts an inline comment.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace ssrfleet::road {

enum class CrgDataFormat { lrfi, ldfi, krbi, kdbi };

inline constexpr std::size_t crg_header_line_chars = 72;
inline constexpr std::size_t crg_record_bytes = 80;

inline bool is_text(CrgDataFormat f) { return f == CrgDataFormat::lrfi || f == CrgDataFormat::ldfi; }
inline bool is_double(CrgDataFormat f) { return f == CrgDataFormat::ldfi || f == CrgDataFormat::kdbi; }
// Characters of a text field or bytes of a binary value.
inline std::size_t value_size(CrgDataFormat f) {
  return is_text(f) ? (is_double(f) ? 20 : 10) : (is_double(f) ? 8 : 4);
}
// Text fields on one 80-character line.
inline std::size_t fields_per_line(CrgDataFormat f) { return crg_record_bytes / value_size(f); }

std::string crg_format_name(CrgDataFormat f);  // "LRFI", ...
// "LRFI", "LDFI", "KRBI", "KDBI" (any case); false for anything else.
bool parse_crg_format(std::string_view name, CrgDataFormat& f);

// The next line of `bytes` from `pos` (advanced past its '\n'), without a trailing '\r': the header
// and the text payload read lines the same way.
inline std::string_view next_crg_line(std::string_view bytes, std::size_t& pos) {
  const std::size_t lf = bytes.find('\n', pos);
  const std::size_t stop = lf == std::string_view::npos ? bytes.size() : lf;
  std::string_view line = bytes.substr(pos, stop - pos);
  pos = lf == std::string_view::npos ? bytes.size() : lf + 1;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

}  // namespace ssrfleet::road
