// Reading one field of a JSON object with the file and the field named in every error: the checks
// the posterior file's readers share (io/posterior_json.cpp, io/posterior_json_sites.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "util/errors.hpp"

namespace ssrfleet::io::json_fields {

template <class T>
T get_field(const nlohmann::json& j, const char* key, const std::string& file, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw DataError(file, 0, where + key, "missing");
  const nlohmann::json& v = j.at(key);
  if constexpr (std::is_integral_v<T>) {
    // nlohmann converts any number to an integer by a plain cast, undefined behaviour for 1e300
    // (UBSan, found by fuzz/posterior_json_fuzzer): take whole numbers in T's range only.
    const bool fits =
        v.is_number_unsigned()
            ? v.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max())
            : v.is_number_integer() &&
                  std::cmp_greater_equal(v.get<std::int64_t>(), std::numeric_limits<T>::min()) &&
                  std::cmp_less_equal(v.get<std::int64_t>(), std::numeric_limits<T>::max());
    if (!fits) {
      throw DataError(file, 0, where + key,
                      "must be a whole number from " + std::to_string(std::numeric_limits<T>::min()) +
                          " to " + std::to_string(std::numeric_limits<T>::max()) + ", found " + v.dump());
    }
    return v.is_number_unsigned() ? static_cast<T>(v.get<std::uint64_t>())
                                  : static_cast<T>(v.get<std::int64_t>());
  } else {
    try {
      return v.get<T>();
    } catch (const nlohmann::json::exception&) {
      throw DataError(file, 0, where + key, "has the wrong type");
    }
  }
}

// An array of finite numbers at j[key], named where + key in messages.
inline std::vector<double> finite_numbers(const nlohmann::json& j, const char* key, const std::string& file,
                                          const std::string& where) {
  auto v = get_field<std::vector<double>>(j, key, file, where);
  for (double x : v) {
    if (!std::isfinite(x)) throw DataError(file, 0, where + key, "holds a non-finite number");
  }
  return v;
}

// The same for an array of the cloud (P prefixes the object's fields).
inline std::vector<double> finite_array(const nlohmann::json& j, const char* key, const std::string& file,
                                        const std::string& P) {
  return finite_numbers(j, key, file, P + "cloud.");
}

}  // namespace ssrfleet::io::json_fields
