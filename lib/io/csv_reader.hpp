// A line-oriented CSV reader that remembers where every value came from, so a bad value can be
// reported as file:line:field. Comment lines (first non-blank character '#') and blank lines are
// skipped. Fields are split on commas; surrounding spaces and double quotes are trimmed (our
// formats never quote commas). The reader is incremental so a stream can be read record by record.
#pragma once

#include <cstddef>
#include <istream>
#include <string>
#include <vector>

namespace ssrfleet::io {

struct CsvRow {
  std::size_t line = 0;               // 1-based line number in the source
  std::string raw;                    // the line as read, without its newline
  std::vector<std::string> fields;
};

// Splits one CSV line into trimmed fields.
std::vector<std::string> split_csv_line(const std::string& line);

class CsvReader {
 public:
  // source_name is what messages call the input (a path, or "<stdin>").
  CsvReader(std::istream& in, std::string source_name);

  // Reads the next non-comment, non-blank line. Returns false at end of input. A line longer than
  // kMaxCsvLineBytes (1 MiB) is a DataError (field "line") once that much is read, never read
  // whole; one with more than kMaxCsvColumns (100,000) fields a DataError (field "columns")
  // before it is split (util/line_reader.hpp).
  bool next(CsvRow& row);

  // In follow mode a last line without its newline is a record still being written: it is held
  // back until the rest arrives (call next() again after clearing the stream's EOF state).
  void set_follow(bool follow) { follow_ = follow; }

  const std::string& source_name() const { return source_name_; }
  std::size_t lines_read() const { return line_; }

 private:
  std::istream& in_;
  std::string source_name_;
  std::size_t line_ = 0;
  bool follow_ = false;
  std::string partial_;
};

// Parses a whole field as a finite double. Throws DataError(source, line, field, reason) on
// empty text, trailing junk, NaN or infinity.
double parse_finite(const std::string& text, const std::string& source, std::size_t line,
                    const std::string& field);

// Index of `name` in header, or -1.
long column_index(const std::vector<std::string>& header, const std::string& name);

// The columns prefix1, prefix2, ... in order (each at its first occurrence in the header), up to
// the first number missing. One pass over the header (a name lookup per number would take
// columns^2 steps on a header of 100,000 if_ columns).
std::vector<long> numbered_columns(const std::vector<std::string>& header, const std::string& prefix);

}  // namespace ssrfleet::io
