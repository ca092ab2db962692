// One vocabulary of argument checks, in the spirit of Stan Math's check_positive: each names the
// function and the quantity, so a message reads "PassIntegrator: speed_mps is -3, but must be
// positive". They throw std::invalid_argument (a programming or option error, not file data).
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace ssrfleet {

namespace detail {
template <class T>
[[noreturn]] void fail_check(std::string_view function, std::string_view name, const T& value,
                             std::string_view must) {
  std::ostringstream os;
  os.precision(17);
  os << function << ": " << name << " is " << value << ", but must be " << must;
  throw std::invalid_argument(os.str());
}
}  // namespace detail

inline void check_finite(std::string_view function, std::string_view name, double value) {
  if (!std::isfinite(value)) detail::fail_check(function, name, value, "finite");
}

inline void check_positive(std::string_view function, std::string_view name, double value) {
  if (!(std::isfinite(value) && value > 0.0)) detail::fail_check(function, name, value, "positive");
}

inline void check_nonnegative(std::string_view function, std::string_view name, double value) {
  if (!(std::isfinite(value) && value >= 0.0)) detail::fail_check(function, name, value, "non-negative");
}

template <class T>
inline void check_greater_or_equal(std::string_view function, std::string_view name, T value, T bound) {
  if (!(value >= bound)) {
    std::ostringstream must;
    must << ">= " << bound;
    detail::fail_check(function, name, value, must.str());
  }
}

inline void check_in_range(std::string_view function, std::string_view name, double value, double lo,
                           double hi) {
  if (!(value >= lo && value <= hi)) {
    std::ostringstream must;
    must.precision(17);
    must << "in [" << lo << ", " << hi << "]";
    detail::fail_check(function, name, value, must.str());
  }
}

}  // namespace ssrfleet
