// Numbers as the reproduction's report prints them.
#pragma once

#include <iomanip>
#include <sstream>
#include <string>

namespace ssrfleet::reproduce {

// `precision` significant digits.
inline std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}
// `decimals` digits after the point.
inline std::string fixed(double v, int decimals) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v;
  return s.str();
}
// A share in [0, 1] as a percentage with one decimal.
inline std::string pct(double share) { return fixed(100.0 * share, 1) + " %"; }

}  // namespace ssrfleet::reproduce
