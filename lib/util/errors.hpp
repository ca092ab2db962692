// The error vocabulary of ssrfleet. The library throws these; only bin/main.cpp turns them into
// messages and exit codes (sysexits spirit: 64 usage, 65 data, 66 no input, 70 internal, 74 I/O,
// 75 busy: try again later).
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace ssrfleet {

// A bad option value or a bad combination of options (exit 64).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Input data that is malformed or physically impossible (exit 65). Where the data came from a
// file, the message names the file, the line and the field, so the user can go and fix it.
class DataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
  DataError(const std::string& file, std::size_t line, const std::string& field, const std::string& what)
      : std::runtime_error(location_message(file, line, field, what)),
        file_(file), line_(line), field_(field), reason_(what) {}
  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  const std::string& field() const { return field_; }
  // line 0 means the format has no lines to speak of (JSON): the message then omits it.
  // The reason alone, without the location prefix (for a rejects list or a stream report).
  const std::string& reason() const { return reason_; }

 private:
  static std::string location_message(const std::string& file, std::size_t line, const std::string& field,
                                      const std::string& what) {
    std::string m = file;
    if (line > 0) m.append(":").append(std::to_string(line));
    m.append(": field '").append(field).append("': ").append(what);
    return m;
  }

  std::string file_;
  std::size_t line_ = 0;
  std::string field_;
  std::string reason_;
};

// An input file that does not exist or cannot be opened (exit 66).
class MissingInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Writing an output failed (exit 74).
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A resource another process holds, e.g. a stream state directory locked by a running stream
// (exit 75, EX_TEMPFAIL: the same command may succeed once the holder is done).
class BusyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A numerical failure inside a computation (all weights zero, NaN likelihood): names where.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ssrfleet
