#include "road/erd_format.hpp"

#include <algorithm>
#include <cmath>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "road/road_file.hpp"
#include "util/errors.hpp"

namespace ssrfleet::road {

namespace {

constexpr double kMaxValues = 1e8;  // 800 MB of doubles: far beyond any profile, still allocatable
constexpr std::size_t kKeywordWidth = 8;

struct Line {
  std::string_view text;
  std::size_t number = 0;  // 1-based
  std::size_t end = 0;     // byte offset just past its terminator
};

// The next line of `bytes` from `pos` (without its LF or CRLF).
Line next_line(std::string_view bytes, std::size_t pos, std::size_t number) {
  const std::size_t lf = bytes.find('\n', pos);
  const std::size_t stop = lf == std::string_view::npos ? bytes.size() : lf;
  std::string_view text = bytes.substr(pos, stop - pos);
  if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
  return {text, number, lf == std::string_view::npos ? bytes.size() : lf + 1};
}

// Channel k's fixed-width field of a SHORTNAM or UNITSNAM value, trimmed; empty if missing.
std::string channel_field(std::string_view value, std::size_t k) {
  const std::size_t at = k * kKeywordWidth;
  return at < value.size() ? std::string(trim_blanks(value.substr(at, kKeywordWidth))) : std::string();
}

// One field per channel.
std::vector<std::string> channel_fields(std::string_view value, std::size_t channels) {
  std::vector<std::string> fields(channels);
  for (std::size_t k = 0; k < channels; ++k) fields[k] = channel_field(value, k);
  return fields;
}

// Metres per unit of a height channel or of the distance axis; 0 if unknown.
double metres_per(std::string unit) {
  for (char& c : unit) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (unit.empty() || unit == "m") return 1.0;
  if (unit == "mm") return 1e-3;
  if (unit == "cm") return 1e-2;
  if (unit == "in" || unit == "inch" || unit == "inches") return 0.0254;
  if (unit == "ft" || unit == "feet") return 0.3048;
  return 0.0;
}

// A whole positive number written as a real or an integer ("3", "3.", "3.0").
bool whole_positive(double v) { return std::isfinite(v) && v >= 1.0 && v == std::floor(v) && v <= 9e15; }

}  // namespace

LongitudinalProfiles read_erd(std::string_view bytes, const std::string& source) {
  Line line = next_line(bytes, 0, 1);
  if (trim_blanks(line.text).substr(0, 9) != "ERDFILEV2") {
    throw DataError(source, 1, "ERDFILEV2.00",
                    "not an ERD file: the first line must be ERDFILEV2.00, found '" +
                        std::string(trim_blanks(line.text).substr(0, 40)) + "'");
  }
  if (line.end >= bytes.size())
    throw DataError(source, 1, "format line", "the file ends after its first line");

  // Line 2: NCHAN, NSAMP, f3, f4, f5, DT, f7
  line = next_line(bytes, line.end, 2);
  std::vector<double> format;
  {
    std::string_view rest = line.text;
    while (true) {
      const std::size_t comma = rest.find(',');
      const std::string_view cell = trim_blanks(rest.substr(0, comma));
      if (!cell.empty() || comma != std::string_view::npos) {
        double v = 0.0;
        if (!cell.empty() && !parse_real(cell, v)) {
          throw DataError(source, 2, "format line field " + std::to_string(format.size() + 1),
                          "'" + std::string(cell) + "' is not a number");
        }
        if (!cell.empty()) format.push_back(v);
      }
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  if (format.size() < 6) {
    throw DataError(
        source, 2, "format line",
        "needs NCHAN, NSAMP, three flags and the sample interval DT (at least 6 numbers), found " +
            std::to_string(format.size()));
  }
  if (!whole_positive(format[0])) {
    throw DataError(
        source, 2, "NCHAN",
        "the number of channels must be a whole number >= 1, found " + shortest_decimal(format[0]));
  }
  if (!whole_positive(format[1]) || format[1] < 2) {
    throw DataError(
        source, 2, "NSAMP",
        "the number of samples must be a whole number >= 2, found " + shortest_decimal(format[1]));
  }
  if (!(std::isfinite(format[5]) && format[5] > 0.0)) {
    throw DataError(source, 2, "DT",
                    "the sample interval must be positive, found " + shortest_decimal(format[5]));
  }
  const double values_declared = format[0] * format[1];
  if (values_declared > kMaxValues) {
    throw DataError(source, 2, "NCHAN x NSAMP",
                    "the header declares " + shortest_decimal(format[0]) + " channels x " +
                        shortest_decimal(format[1]) +
                        " samples, more than the 1e8 values ssrfleet reads (a corrupt header?)");
  }
  const auto channels = static_cast<std::size_t>(format[0]);
  const auto samples = static_cast<std::size_t>(format[1]);

  // Header lines up to END. A later SHORTNAM or UNITSNAM line replaces an earlier one; their values
  // are split into one field per channel only once the data are known to hold that many channels
  // (a header may declare millions of channels in a few bytes, and split each such line again:
  // fuzz/erd_fuzzer timed out on 5 kB of them).
  std::string_view short_names, unit_names;
  std::size_t units_line = 0;
  std::string x_units;
  std::size_t x_units_line = 0;
  bool ended = false;
  std::size_t number = 2;
  while (line.end < bytes.size()) {
    line = next_line(bytes, line.end, ++number);
    const std::string_view keyword = trim_blanks(line.text.substr(0, kKeywordWidth));
    const std::string_view value = line.text.size() > kKeywordWidth ? line.text.substr(kKeywordWidth) : "";
    if (keyword == "END" && trim_blanks(line.text) == "END") {
      ended = true;
      break;
    }
    if (keyword == "SHORTNAM") short_names = value;
    if (keyword == "UNITSNAM") {
      unit_names = value;
      units_line = number;
    }
    if (keyword == "XUNITS") {
      x_units = std::string(trim_blanks(value));
      x_units_line = number;
    }
  }
  if (!ended) throw DataError(source, number, "END", "no END line: the header never ends");

  // Every unit known (a channel past the UNITSNAM value's fields has none: metres).
  const std::size_t named_units = std::min(channels, unit_names.size() / kKeywordWidth + 1);
  for (std::size_t k = 0; k < named_units; ++k) {
    const std::string unit = channel_field(unit_names, k);
    if (metres_per(unit) == 0.0) {
      throw DataError(
          source, units_line, "UNITSNAM",
          "unknown unit '" + unit + "' of channel " + std::to_string(k + 1) + " (m, mm, cm, in, ft)");
    }
  }
  const double x_scale = metres_per(x_units);
  if (x_scale == 0.0)
    throw DataError(source, x_units_line, "XUNITS", "unknown distance unit '" + x_units + "' (m, ft)");

  // The data: every value needs at least one character and one separator, so a short file is
  // refused before anything is allocated.
  const std::size_t data_begin = line.end;
  const auto values = static_cast<std::size_t>(values_declared);
  if (bytes.size() - data_begin < 2 * values - 1) {
    throw DataError(source, number, "data",
                    "truncated: the header declares " + std::to_string(samples) + " samples x " +
                        std::to_string(channels) + " channels, but only " +
                        std::to_string(bytes.size() - data_begin) + " bytes of data follow END");
  }
  // The data hold at least 2 bytes per value, so the per-channel fields are bounded by the file.
  const std::vector<std::string> labels = channel_fields(short_names, channels);
  std::vector<double> scale(channels);
  for (std::size_t k = 0; k < channels; ++k) scale[k] = metres_per(channel_field(unit_names, k));
  LongitudinalProfiles p;
  p.name = source;
  p.dx_m = format[5] * x_scale;
  p.height_m.resize(static_cast<Eigen::Index>(samples), static_cast<Eigen::Index>(channels));
  std::size_t count = 0;
  std::size_t pos = data_begin;
  std::size_t data_line = number + 1;
  std::size_t last_value_line = number;  // where the data ended, for a truncation
  const auto separator = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r' || c == '\n'; };
  while (pos < bytes.size()) {
    if (separator(bytes[pos])) {
      if (bytes[pos] == '\n') ++data_line;
      ++pos;
      continue;
    }
    std::size_t stop = pos;
    while (stop < bytes.size() && !separator(bytes[stop])) ++stop;
    const std::string_view token = bytes.substr(pos, stop - pos);
    if (count == values) {
      throw DataError(source, data_line, "data",
                      "more values than the header's " + std::to_string(samples) + " samples x " +
                          std::to_string(channels) + " channels (the first extra one is '" +
                          std::string(token.substr(0, 24)) + "')");
    }
    const std::size_t sample = count / channels, channel = count % channels;
    double v = 0.0;
    if (!parse_real(token, v) || !std::isfinite(v)) {
      throw DataError(source, data_line, "channel " + std::to_string(channel + 1),
                      "sample " + std::to_string(sample + 1) + ": '" + std::string(token.substr(0, 24)) +
                          "' is not a finite number");
    }
    p.height_m(static_cast<Eigen::Index>(sample), static_cast<Eigen::Index>(channel)) = v * scale[channel];
    ++count;
    last_value_line = data_line;
    pos = stop;
  }
  if (count < values) {
    throw DataError(source, last_value_line, "data",
                    "truncated: the header declares " + std::to_string(samples) + " samples x " +
                        std::to_string(channels) + " channels = " + std::to_string(values) +
                        " values, the data hold " + std::to_string(count));
  }
  for (std::size_t k = 0; k < channels; ++k) {
    p.labels.push_back(labels[k].empty() ? "profile " + std::to_string(k + 1) : labels[k]);
  }
  return p;
}

LongitudinalProfiles read_erd_file(const std::string& path) {
  return read_erd(read_whole_file(path, "ERD profile file"), path);
}

void write_erd(const LongitudinalProfiles& profiles, std::ostream& out) {
  if (!profiles.height_m.allFinite()) {
    throw std::invalid_argument("write_erd: profiles of '" + profiles.name +
                                "' hold a missing or non-finite height");
  }
  const auto field = [](std::string text) {
    text.resize(kKeywordWidth, ' ');
    return text;
  };
  std::string header = "ERDFILEV2.00\n";
  header += std::to_string(profiles.profiles()) + ", " + std::to_string(profiles.samples()) + ", -1, 1, 5, " +
            shortest_decimal(profiles.dx_m) + ", -1,\n";
  std::string title = "ssrfleet profiles of " + profiles.name;
  header += field("TITLE") + title.substr(0, 72) + "\n";
  header += field("SHORTNAM");
  for (const std::string& label : profiles.labels) header += field(label);
  header += '\n';
  header += field("UNITSNAM");
  for (Eigen::Index k = 0; k < profiles.profiles(); ++k) header += field("m");
  header += '\n';
  header += field("GENERIC");
  for (Eigen::Index k = 0; k < profiles.profiles(); ++k) header += field("Elev.");
  header += '\n';
  header += field("XNAME");
  header += "Distance\n";
  header += field("XUNITS");
  header += "m\nEND\n";
  out << header;
  std::string row;
  for (Eigen::Index i = 0; i < profiles.samples(); ++i) {
    row.clear();
    for (Eigen::Index k = 0; k < profiles.profiles(); ++k) {
      row += ' ';
      row += shortest_decimal(profiles.height_m(i, k));
    }
    row += '\n';
    out << row;
  }
}

void write_erd_file(const LongitudinalProfiles& profiles, const std::string& path) {
  write_file_atomically(path, "ERD profile file", [&](std::ostream& out) { write_erd(profiles, out); });
}

}  // namespace ssrfleet::road
