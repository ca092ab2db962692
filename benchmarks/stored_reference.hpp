// A stored batch-MCMC reference (the JSON mcmc_reference_benchmark writes), read back so that
// ratio_benchmark --reference can judge SMC fits against a chain far longer than it could run
// beside them (at 10,000 trucks: 160,000 sweeps, 88 minutes). The file must be
// for the same fleet preset and data seed; anything missing or malformed is refused with the
// file and the field named.
#pragma once

#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "model/fleet_model.hpp"

namespace ssrfleet::bench {

struct StoredReference {
  std::string path;
  std::string fleet;
  int trucks = 0;
  int iterations = 0, burn_in = 0;
  std::uint64_t seed = 0;
  std::string commit;
  fleet::HyperVector mean{}, sd{}, ess{};
};

namespace detail {

inline const nlohmann::json& required_field(const nlohmann::json& j, const std::string& key, const std::string& path,
                                            const std::string& where) {
  if (!j.is_object() || !j.contains(key))
    throw std::runtime_error("reference '" + path + "': no field '" + where + key + "'");
  return j.at(key);
}

inline double required_number(const nlohmann::json& j, const std::string& key, const std::string& path,
                              const std::string& where) {
  const nlohmann::json& v = required_field(j, key, path, where);
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw std::runtime_error("reference '" + path + "': field '" + where + key + "' is not a finite number");
  return v.get<double>();
}

// A whole number in [0, max]: converting a double outside the target's range is undefined.
inline double required_count(const nlohmann::json& j, const std::string& key, const std::string& path, double max) {
  const double v = required_number(j, key, path, "");
  if (!(v >= 0.0 && v <= max && v == std::floor(v)))
    throw std::runtime_error("reference '" + path + "': field '" + key + "' is not a whole number in [0, " +
                             std::to_string(static_cast<long long>(max)) + "]");
  return v;
}

}  // namespace detail

inline StoredReference read_stored_reference(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("reference '" + path + "': cannot open");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw std::runtime_error("reference '" + path + "': not JSON (" + e.what() + ")");
  }
  using detail::required_field;
  using detail::required_number;
  const nlohmann::json& kind = required_field(j, "benchmark", path, "");
  if (kind != "mcmc_reference")
    throw std::runtime_error("reference '" + path + "': field 'benchmark' is " + kind.dump() +
                             ", not \"mcmc_reference\" (a file written by mcmc_reference_benchmark)");
  StoredReference r;
  r.path = path;
  const nlohmann::json& fleet_name = required_field(j, "fleet", path, "");
  if (!fleet_name.is_string()) throw std::runtime_error("reference '" + path + "': field 'fleet' is not a string");
  r.fleet = fleet_name.get<std::string>();
  constexpr double kIntMax = 2147483647.0, kSeedMax = 9007199254740992.0;  // 2^53: exact in a double
  r.trucks = static_cast<int>(detail::required_count(j, "trucks", path, kIntMax));
  r.iterations = static_cast<int>(detail::required_count(j, "iterations", path, kIntMax));
  r.burn_in = static_cast<int>(detail::required_count(j, "burn_in", path, kIntMax));
  r.seed = static_cast<std::uint64_t>(detail::required_count(j, "seed", path, kSeedMax));
  if (j.contains("commit") && j["commit"].is_string()) r.commit = j["commit"].get<std::string>();
  const nlohmann::json& post = required_field(j, "posterior", path, "");
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const std::string name(fleet::kHyperNames[h]);
    const nlohmann::json& p = required_field(post, name, path, "posterior.");
    const std::string where = "posterior." + name + ".";
    const auto H = static_cast<std::size_t>(h);
    r.mean[H] = required_number(p, "mean", path, where);
    r.sd[H] = required_number(p, "sd", path, where);
    r.ess[H] = required_number(p, "ess", path, where);
    if (!(r.sd[H] > 0.0)) throw std::runtime_error("reference '" + path + "': field '" + where + "sd' is not positive");
  }
  return r;
}

}  // namespace ssrfleet::bench
