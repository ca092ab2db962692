#include "road/crg_payload.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

#include "road/crg_format.hpp"
#include "road/road_file.hpp"
#include "util/errors.hpp"

namespace ssrfleet::road {

namespace {

bool is_nan_bytes(std::string_view b, bool dbl) {
  if (dbl) {
    std::uint64_t u = 0;
    for (const char c : b.substr(0, 8)) u = (u << 8) | static_cast<unsigned char>(c);
    return std::isnan(std::bit_cast<double>(u));
  }
  std::uint32_t u = 0;
  for (const char c : b.substr(0, 4)) u = (u << 8) | static_cast<unsigned char>(c);
  return std::isnan(std::bit_cast<float>(u));
}

double big_endian_value(const char* p, bool dbl) {
  if (dbl) {
    std::uint64_t u = 0;
    for (int i = 0; i < 8; ++i) u = (u << 8) | static_cast<unsigned char>(p[i]);
    return std::bit_cast<double>(u);
  }
  std::uint32_t u = 0;
  for (int i = 0; i < 4; ++i) u = (u << 8) | static_cast<unsigned char>(p[i]);
  return static_cast<double>(std::bit_cast<float>(u));
}

}  // namespace

void decode_binary(std::string_view bytes, const CrgHeader& h, std::size_t declared, RowSink& sink,
                   const std::string& source) {
  const bool dbl = is_double(h.format);
  const std::size_t value_bytes = value_size(h.format);
  const std::size_t channels = h.channels.size();
  const std::size_t row_bytes = value_bytes * channels;
  const std::string_view payload = bytes.substr(h.payload_offset);
  const std::size_t size = payload.size();
  const auto offset_text = [&](std::size_t in_payload) {
    return "byte offset " + std::to_string(h.payload_offset + in_payload);
  };
  if (size % value_bytes != 0) {
    throw DataError(source, 0, crg_format_name(h.format) + " payload",
                    "truncated: the payload of " + std::to_string(size) + " bytes ends inside a value at " +
                        offset_text(size - size % value_bytes));
  }
  std::size_t rows = 0;
  if (declared > 0) {
    if (declared * row_bytes > size) {
      throw DataError(source, 0, crg_format_name(h.format) + " payload",
                      "truncated: REFERENCE_LINE_END_U declares " + std::to_string(declared) +
                          " cross sections of " + std::to_string(channels) + " channels (" +
                          std::to_string(declared * row_bytes) + " bytes), the payload ends after " +
                          std::to_string(size) + " bytes (" + offset_text(size) + ")");
    }
    rows = declared;
    const std::size_t rest = size - rows * row_bytes;
    bool padding = rest < crg_record_bytes;
    for (std::size_t at = rows * row_bytes; padding && at < size; at += value_bytes) {
      padding = is_nan_bytes(payload.substr(at), dbl);
    }
    if (!padding) {
      throw DataError(source, 0, crg_format_name(h.format) + " payload",
                      "counts disagree: REFERENCE_LINE_END_U declares " + std::to_string(declared) +
                          " cross sections, but data go on past them from " + offset_text(rows * row_bytes) +
                          " (" + std::to_string(rest) + " more bytes)");
    }
  } else {
    // No declared count: the whole rows, less the padding. Padding fills the last 80-byte record
    // with NaNs, so it is under 80 bytes; a real cross section is never all NaN (the spec wants
    // one valid value in each), so all-NaN rows within the last 80 bytes are padding.
    std::size_t whole = size / row_bytes;
    const auto all_nan = [&](std::size_t from, std::size_t to) {
      for (std::size_t at = from; at < to; at += value_bytes) {
        if (!is_nan_bytes(payload.substr(at), dbl)) return false;
      }
      return true;
    };
    if (size - whole * row_bytes >= crg_record_bytes || !all_nan(whole * row_bytes, size)) {
      throw DataError(source, 0, crg_format_name(h.format) + " payload",
                      "truncated: the last cross section is incomplete (" +
                          std::to_string(size - whole * row_bytes) + " of its " + std::to_string(row_bytes) +
                          " bytes) at " + offset_text(whole * row_bytes));
    }
    while (whole > 0 && size - (whole - 1) * row_bytes < crg_record_bytes &&
           all_nan((whole - 1) * row_bytes, whole * row_bytes)) {
      --whole;
    }
    const std::size_t end = whole * row_bytes;
    rows = end / row_bytes;
    if (static_cast<double>(rows) * static_cast<double>(channels) > kMaxCrgCells) {
      throw DataError(source, 0, crg_format_name(h.format) + " payload",
                      "more than the 1e8 values ssrfleet reads");
    }
  }
  if (rows < 2) {
    throw DataError(source, 0, crg_format_name(h.format) + " payload",
                    "needs at least 2 cross sections, found " + std::to_string(rows));
  }
  sink.reserve(rows);
  std::vector<double> values(channels);
  for (std::size_t r = 0; r < rows; ++r) {
    const char* p = payload.data() + r * row_bytes;
    for (std::size_t c = 0; c < channels; ++c) values[c] = big_endian_value(p + c * value_bytes, dbl);
    sink.row(r, values);
  }
}

void decode_text(std::string_view bytes, const CrgHeader& h, std::size_t declared, RowSink& sink,
                 const std::string& source) {
  const std::size_t width = value_size(h.format);
  const std::size_t per_line = fields_per_line(h.format);
  const std::size_t channels = h.channels.size();
  const std::size_t lines_per_row = (channels + per_line - 1) / per_line;
  struct Span {
    std::string_view text;
    std::size_t number;
  };
  std::vector<Span> lines;
  std::size_t pos = h.payload_offset, number = h.end_line;
  while (pos < bytes.size()) {
    std::string_view line = next_crg_line(bytes, pos);
    ++number;
    if (trim_blanks(line).empty()) continue;
    lines.push_back({line, number});
  }
  const std::string field_name = crg_format_name(h.format) + " payload";
  if (lines.size() % lines_per_row != 0) {
    throw DataError(source, lines.back().number, field_name,
                    "truncated: the last cross section has " + std::to_string(lines.size() % lines_per_row) +
                        " of its " + std::to_string(lines_per_row) + " lines (" + std::to_string(channels) +
                        " channels, " + std::to_string(per_line) + " to a line)");
  }
  const std::size_t rows = lines.size() / lines_per_row;
  if (declared > 0 && rows != declared) {
    throw DataError(source,
                    rows < declared ? (lines.empty() ? number : lines.back().number)
                                    : lines[declared * lines_per_row].number,
                    field_name,
                    std::string(rows < declared ? "truncated" : "counts disagree") +
                        ": REFERENCE_LINE_END_U declares " + std::to_string(declared) +
                        " cross sections, the payload holds " + std::to_string(rows));
  }
  if (rows < 2) {
    throw DataError(source, number, field_name,
                    "needs at least 2 cross sections, found " + std::to_string(rows));
  }
  if (static_cast<double>(rows) * static_cast<double>(channels) > kMaxCrgCells) {
    throw DataError(source, lines.back().number, field_name, "more than the 1e8 values ssrfleet reads");
  }
  sink.reserve(rows);
  std::vector<double> values(channels);
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t l = 0; l < lines_per_row; ++l) {
      const Span& span = lines[r * lines_per_row + l];
      const std::size_t first = l * per_line;
      const std::size_t fields = std::min(per_line, channels - first);
      if (!trim_blanks(span.text.substr(std::min(span.text.size(), fields * width))).empty()) {
        throw DataError(source, span.number, field_name,
                        "more than " + std::to_string(fields) + " fields of " + std::to_string(width) +
                            " characters on this line (column " + std::to_string(fields * width + 1) +
                            " on)");
      }
      for (std::size_t f = 0; f < fields; ++f) {
        const std::size_t column = f * width;
        const std::string_view cell =
            column < span.text.size() ? trim_blanks(span.text.substr(column, width)) : std::string_view{};
        const std::string where =
            "channel " + std::to_string(first + f + 1) + " (column " + std::to_string(column + 1) + ")";
        if (cell.empty()) {
          throw DataError(source, span.number, where,
                          "blank field: every field of " + std::to_string(width) +
                              " characters holds a number or a '*' placeholder for a missing value");
        }
        double v = std::numeric_limits<double>::quiet_NaN();
        if (cell.front() != '*' && (!parse_real(cell, v) || !std::isfinite(v))) {  // a missing value is '*...'
          throw DataError(source, span.number, where,
                          "'" + std::string(cell) + "' is not a number (" + crg_format_name(h.format) +
                              " fields are " + std::to_string(width) + " characters wide)");
        }
        values[first + f] = v;
      }
    }
    sink.row(r, values);
  }
}

}  // namespace ssrfleet::road
