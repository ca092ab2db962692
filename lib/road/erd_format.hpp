// The UMTRI ERD file (ERDFILEV2.00, text data), the exchange format of longitudinal road profiles
// (RoadRuf, ProVAL, the LTPP profile data). Layout as ssrfleet reads and writes it:
//   ERDFILEV2.00                                   line 1: identifies the format
//   NCHAN, NSAMP, f3, f4, f5, DT, f7,              line 2: channels, samples per channel, ...,
//                                                          sample interval (in XUNITS)
//   KEYWORD value                                  header lines: an 8-character keyword, then the
//   ...                                            value; SHORTNAM and UNITSNAM give one
//                                                  8-character field per channel
//   END                                            ends the header
//   v11 v12 ... v1N                                the data: NSAMP rows of NCHAN numbers, separated
//   ...                                            by blanks or commas (any line breaks)
// Read: NCHAN, NSAMP, DT (fields 1, 2, 6); f3-f5 and f7 are read past. SHORTNAM labels the
// profiles; UNITSNAM's units (m, mm, cm, in, ft; blank = m) convert heights to metres; XUNITS (m,
// ft; blank = m) the interval. Binary ERD (data in a companion .bin file) is not read.
// Written: f3-f5 and f7 as in LTPP's published text ERD files (-1, 1, 5 and -1), heights in metres
// in the shortest decimal that reads back to the same double, so write -> read keeps every bit.
//
// Defects are ssrfleet::DataError naming the file, the line and the field: a first line other
// than ERDFILEV2.*, a format line with fewer than 6 numbers or a non-number in one, channels or
// samples not a positive whole number, an interval not positive, a size beyond 1e8 values, a
// header without END, an unknown unit, a data value that is not a finite number (field "channel
// k", sample named), fewer values than NCHAN x NSAMP ("truncated") or more.
#pragma once

#include <iosfwd>
#include <string>
#include <string_view>

#include "road/longitudinal_profiles.hpp"

namespace ssrfleet::road {

// `source` names the input in messages and becomes profiles.name.
LongitudinalProfiles read_erd(std::string_view text, const std::string& source);
// Missing or unreadable file -> ssrfleet::MissingInputError naming the path.
LongitudinalProfiles read_erd_file(const std::string& path);

// Labels are cut to the 8 characters of a SHORTNAM field.
void write_erd(const LongitudinalProfiles& profiles, std::ostream& out);
// Atomic (temporary file, then rename); failure -> ssrfleet::IoError naming the path.
void write_erd_file(const LongitudinalProfiles& profiles, const std::string& path);

}  // namespace ssrfleet::road
