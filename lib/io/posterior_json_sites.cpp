#include "io/posterior_json_sites.hpp"

#include <cstddef>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "io/json_fields.hpp"
#include "io/posterior_json.hpp"
#include "site/sensor_array.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

using json_fields::finite_numbers;
using json_fields::get_field;

// The sites of a fit over several (posterior_cloud.hpp, CloudSite), after the pool is read: each
// site's pool a range of it, the ranges in order and covering it, the names distinct.
void parse_posterior_sites(const nlohmann::json& sites, const std::string& path, const std::string& where,
                           fleet::PosteriorCloud& c) {
  if (!sites.is_array() || sites.size() < 2) throw DataError(path, 0, where, "must list at least two sites");
  if (sites.size() > kMaxPosteriorSites) {
    throw DataError(path, 0, where,
                    "lists " + std::to_string(sites.size()) + " sites, more than this build reads (" +
                        std::to_string(kMaxPosteriorSites) + ")");
  }
  std::size_t next = 0;
  long trucks = 0;
  std::unordered_set<std::string> names;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    const std::string P = where + "[" + std::to_string(i) + "].";
    const nlohmann::json& e = sites[i];
    fleet::CloudSite s;
    s.name = get_field<std::string>(e, "name", path, P);
    s.fingerprint = get_field<std::string>(e, "fingerprint", path, P);
    s.road_name = get_field<std::string>(e, "road", path, P);
    s.sensors = get_field<int>(e, "sensors", path, P);
    s.lateral_min_m = get_field<double>(e, "lateral_min_m", path, P);
    s.lateral_max_m = get_field<double>(e, "lateral_max_m", path, P);
    s.trucks_seen = get_field<long>(e, "trucks_seen", path, P);
    if (s.name.empty()) throw DataError(path, 0, P + "name", "is empty");
    if (!names.insert(s.name).second)
      throw DataError(path, 0, P + "name", "'" + s.name + "' names two sites");
    if (s.sensors < 1 || !(s.lateral_min_m < s.lateral_max_m)) {
      throw DataError(path, 0, P + "sensors", "impossible site (sensors or lateral range)");
    }
    // The sites' trucks add up to the file's: each at most what the others leave (no overflow).
    if (s.trucks_seen < 0 || c.trucks_seen < trucks || s.trucks_seen > c.trucks_seen - trucks) {
      throw DataError(path, 0, P + "trucks_seen",
                      "must be from 0 to the file's trucks_seen less the sites before it");
    }
    // Two whole numbers, each through get_field's range check (a cast of 1e300 would be undefined).
    const nlohmann::json& pool_json = e.contains("pool") ? e["pool"] : nlohmann::json();
    if (!pool_json.is_array() || pool_json.size() != 2) {
      throw DataError(path, 0, P + "pool", "must be [first, count]: the site's trucks in cloud.speed_mps");
    }
    const nlohmann::json pool_object = {{"first", pool_json[0]}, {"count", pool_json[1]}};
    const std::uint64_t pool[2] = {get_field<std::uint64_t>(pool_object, "first", path, P + "pool."),
                                   get_field<std::uint64_t>(pool_object, "count", path, P + "pool.")};
    // A site may have no trucks in one vehicle class's fit (its pool is then empty).
    if (pool[0] != next || pool[1] > c.speed_mps.size() - next || (pool[1] == 0) != (s.trucks_seen == 0)) {
      throw DataError(path, 0, P + "pool",
                      "must be [first, count]: the site's trucks in cloud.speed_mps, from " +
                          std::to_string(next) + ", within the " + std::to_string(c.speed_mps.size()) +
                          " there are, none only for a site "
                          "with no trucks");
    }
    s.pool_begin = pool[0];
    s.pool_count = pool[1];
    next += s.pool_count;
    trucks += s.trucks_seen;
    c.sites.push_back(std::move(s));
  }
  if (next != c.speed_mps.size()) {
    throw DataError(path, 0, where,
                    "the sites' pools hold " + std::to_string(next) + " of the " +
                        std::to_string(c.speed_mps.size()) + " trucks in cloud.speed_mps");
  }
  if (trucks != c.trucks_seen) {
    throw DataError(path, 0, where,
                    "the sites' trucks_seen add up to " + std::to_string(trucks) + ", not the file's " +
                        std::to_string(c.trucks_seen));
  }
}

// The sensor calibration of the sites (posterior_cloud.hpp, SiteCalibration): per site its name, its
// gains (positive) and, if they were fitted, their standard errors (one per gain, >= 0).
void parse_posterior_calibration(const nlohmann::json& list, const std::string& path,
                                 const std::string& where, fleet::PosteriorCloud& c) {
  if (!list.is_array() || list.empty())
    throw DataError(path, 0, where, "must be a non-empty array of sites' gains");
  if (list.size() > kMaxPosteriorSites) {
    throw DataError(path, 0, where,
                    "lists " + std::to_string(list.size()) + " sites, more than this build reads (" +
                        std::to_string(kMaxPosteriorSites) + ")");
  }
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string P = where + "[" + std::to_string(i) + "].";
    const nlohmann::json& e = list[i];
    if (!e.is_object()) throw DataError(path, 0, where + "[" + std::to_string(i) + "]", "must be an object");
    fleet::SiteCalibration s;
    s.site = get_field<std::string>(e, "site", path, P);
    s.gain = finite_numbers(e, "gain", path, P);
    if (s.gain.empty() || s.gain.size() > static_cast<std::size_t>(site::kMaxSensors)) {
      throw DataError(path, 0, P + "gain", "must hold one gain per sensor");
    }
    for (double g : s.gain) {
      if (!(g > 0.0)) throw DataError(path, 0, P + "gain", "holds a gain that is not positive");
    }
    if (e.contains("se")) {
      s.se = finite_numbers(e, "se", path, P);
      if (s.se.size() != s.gain.size())
        throw DataError(path, 0, P + "se", "needs one standard error per gain");
      for (double x : s.se) {
        if (x < 0.0) throw DataError(path, 0, P + "se", "holds a negative standard error");
      }
    }
    c.calibration.push_back(std::move(s));
  }
}

}  // namespace ssrfleet::io
