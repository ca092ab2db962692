// Reading a text line with a ceiling on its length (absurd inputs fail fast).
// std::getline reads a line whatever its length, so a 1 GB line (a binary file passed as a log, a
// log with its newlines stripped) is taken into memory before anything can refuse it, and a
// larger one ends in an out-of-memory kill. read_bounded_line stops after max_bytes characters
// instead, having read and stored no more than that, and says so; the caller throws its DataError
// naming the file and the line. It lives in util because the CSV reader of io and the road CSV of
// road (which sits below io) both read lines this way.
//
// The limits of the text formats (docs/site-data.md) are here, in one place.
#pragma once

#include <cstddef>
#include <istream>
#include <string>

namespace ssrfleet {

// The longest line a CSV input may hold (WIM log, force log, truck list, road CSV): 1 MiB. A WIM
// line is about 200 bytes; a road CSV row of 10,000 lateral lines at 20 characters is 200 KB.
inline constexpr std::size_t kMaxCsvLineBytes = std::size_t{1} << 20;
// The most fields a CSV line may hold: 100,000 (a WIM log has about 20; a road CSV one per lateral
// line, 101 for the presets' 5 m at 5 cm).
inline constexpr std::size_t kMaxCsvColumns = 100'000;
// The most values (rows x lateral lines) a road surface may hold, whatever its format: 1e8 (800 MB
// of heights), the same ceiling as the OpenCRG and ERD readers.
inline constexpr double kMaxSurfaceCells = 1e8;

enum class LineRead {
  line,           // a whole line, its '\n' consumed and not stored
  no_newline,     // the last line of the input, without its '\n' (eofbit is set, as std::getline does)
  end,            // nothing left (failbit and eofbit set, as std::getline does)
  too_long,       // more than max_bytes before a '\n': `line` holds the first max_bytes, the rest is unread
};

// Like std::getline(in, line), but never stores more than max_bytes characters.
inline LineRead read_bounded_line(std::istream& in, std::string& line, std::size_t max_bytes) {
  line.clear();
  const std::istream::sentry ok(in, /*noskipws=*/true);
  if (!ok) return LineRead::end;
  std::streambuf& buffer = *in.rdbuf();
  using traits = std::istream::traits_type;
  for (;;) {
    const traits::int_type c = buffer.sbumpc();
    if (traits::eq_int_type(c, traits::eof())) {
      if (line.empty()) {
        in.setstate(std::ios::eofbit | std::ios::failbit);
        return LineRead::end;
      }
      in.setstate(std::ios::eofbit);
      return LineRead::no_newline;
    }
    if (traits::to_char_type(c) == '\n') return LineRead::line;
    if (line.size() == max_bytes) {
      buffer.sungetc();  // leave the character after the limit unread
      return LineRead::too_long;
    }
    line.push_back(traits::to_char_type(c));
  }
}

}  // namespace ssrfleet
