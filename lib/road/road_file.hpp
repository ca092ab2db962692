// What every road-file reader and writer of lib/road shares: reading a whole file, writing one
// atomically, trimming, and parsing a number the way measured-data files write them. (lib/io has
// its own atomic writer, but the road layer sits below io: `--road FILE` is read by lib/site.)
#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <string_view>

namespace ssrfleet::road {

// The whole file as bytes. Missing, not a regular file or unreadable -> MissingInputError naming
// `what` ("road surface file") and the path.
std::string read_whole_file(const std::string& path, const std::string& what);

// Calls write(stream) on `path.tmp.<pid>` and renames it onto `path`, so a failure never leaves
// a partial file; the temporary is removed on every failure, including an exception from write.
// Failure -> IoError naming `what` and the path.
void write_file_atomically(const std::string& path, const std::string& what,
                           const std::function<void(std::ostream&)>& write);

std::string_view trim_blanks(std::string_view s);  // spaces, tabs, CR at both ends

// The whole of `text` as a double, accepting Fortran's D exponent (1.5D-03) that profilometer
// and OpenCRG text files may carry. False for an empty cell, trailing characters, or a value out
// of range; NaN and infinities parse (callers decide whether they are allowed).
bool parse_real(std::string_view text, double& value);

// The shortest decimal that reads back to the same double (std::to_chars).
std::string shortest_decimal(double value);

}  // namespace ssrfleet::road
