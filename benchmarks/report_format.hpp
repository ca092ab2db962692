// Small pieces the benchmarks' JSON and Markdown writers share: fixed-precision numbers that say
// "n/a" rather than "nan", JSON nulls for non-finite values, one JSON object per hyperparameter,
// and a results file that complains when it cannot be written (a benchmark that ran for an hour
// and silently wrote nothing is the worst outcome).
#pragma once

#include <array>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "model/fleet_model.hpp"

namespace ssrfleet::bench {

inline std::string fmt(double v, int prec = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s << std::fixed << std::setprecision(prec) << v;
  return s.str();
}

// Six significant digits, for posterior means and sds of very different scales.
inline std::string fmt_g(double v) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

inline nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

template <class T>
nlohmann::json hyper_json(const std::array<T, fleet::kHyperCount>& v) {
  nlohmann::json j = nlohmann::json::object();
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const T& x = v[static_cast<std::size_t>(h)];
    if constexpr (std::is_floating_point_v<T>)
      j[std::string(fleet::kHyperNames[h])] = num(x);
    else
      j[std::string(fleet::kHyperNames[h])] = x;
  }
  return j;
}

// Opens `path` for writing; on failure says so on stderr (the stream is then in a failed state
// and writes to it do nothing).
inline std::ofstream open_results_file(const std::string& path) {
  std::ofstream f(path);
  if (!f) std::cerr << "warning: cannot write " << path << "\n";
  return f;
}

}  // namespace ssrfleet::bench
