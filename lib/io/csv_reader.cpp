#include "io/csv_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <string_view>
#include <unordered_map>

#include "util/errors.hpp"
#include "util/line_reader.hpp"

namespace ssrfleet::io {

namespace {
std::string trim(const std::string& s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r' || s[b] == '"')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r' || s[e - 1] == '"')) --e;
  return s.substr(b, e - b);
}

bool is_skippable(const std::string& line) {
  for (char c : line) {
    if (c == ' ' || c == '\t' || c == '\r') continue;
    return c == '#';
  }
  return true;  // blank
}
}  // namespace

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

CsvReader::CsvReader(std::istream& in, std::string source_name)
    : in_(in), source_name_(std::move(source_name)) {}

bool CsvReader::next(CsvRow& row) {
  std::string line;
  for (;;) {
    // A held-back partial line counts towards the limit of the line it begins.
    const LineRead got = read_bounded_line(in_, line, kMaxCsvLineBytes - std::min(partial_.size(), kMaxCsvLineBytes));
    if (got == LineRead::end) return false;
    if (got == LineRead::too_long) {
      throw DataError(source_name_, line_ + 1, "line",
                      "the line is longer than " + std::to_string(kMaxCsvLineBytes) +
                          " bytes (1 MiB), the most a CSV line may hold; not read further (is this a CSV file, "
                          "with its line ends?)");
    }
    if (got == LineRead::no_newline && follow_) {  // no newline yet: the writer is mid-record
      partial_ += line;
      return false;
    }
    if (!partial_.empty()) {
      line = partial_ + line;
      partial_.clear();
    }
    ++line_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (is_skippable(line)) continue;
    const auto commas = static_cast<std::size_t>(std::count(line.begin(), line.end(), ','));
    if (commas >= kMaxCsvColumns) {
      throw DataError(source_name_, line_, "columns",
                      "the line has " + std::to_string(commas + 1) + " fields, more than the " +
                          std::to_string(kMaxCsvColumns) + " a CSV line may hold");
    }
    row.line = line_;
    row.fields = split_csv_line(line);
    row.raw = std::move(line);
    return true;
  }
}

double parse_finite(const std::string& text, const std::string& source, std::size_t line,
                    const std::string& field) {
  if (text.empty()) throw DataError(source, line, field, "empty value, expected a number");
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  if (end == begin || *end != '\0') {
    throw DataError(source, line, field, "'" + text + "' is not a number");
  }
  if (!std::isfinite(value) || errno == ERANGE) {
    throw DataError(source, line, field, "'" + text + "' is not a finite number");
  }
  return value;
}

long column_index(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<long>(i);
  }
  return -1;
}

std::vector<long> numbered_columns(const std::vector<std::string>& header, const std::string& prefix) {
  std::unordered_map<std::string_view, long> index;
  for (std::size_t i = 0; i < header.size(); ++i) index.emplace(header[i], static_cast<long>(i));
  std::vector<long> cols;
  for (std::size_t m = 1;; ++m) {
    const auto found = index.find(prefix + std::to_string(m));
    if (found == index.end()) return cols;
    cols.push_back(found->second);
  }
}

}  // namespace ssrfleet::io
