// The MS-WIM sensor array: equally spaced sensors along the wheel path. Default: the paper's 16
// sensors at 76.0, 77.5, ..., 98.5 m (the 0-76 m approach lets the start transient die out).
#pragma once

#include <vector>

namespace ssrfleet::site {

// The most sensors a site may have (docs/site-data.md): an MS-WIM array has tens; a log of more
// would not fit a CSV line's 100,000 fields, and 1e9 positions are 8 GB before anything checks them.
inline constexpr int kMaxSensors = 10'000;

struct SensorArray {
  double first_m = 76.0;
  double spacing_m = 1.5;
  int count = 16;

  // Throws UsageError unless first >= 0, spacing > 0 (or count == 1) and 1 <= count <= 10,000.
  void validate() const;
  std::vector<double> positions_m() const;
};

}  // namespace ssrfleet::site
