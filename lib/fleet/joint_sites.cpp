#include "fleet/joint_sites.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

std::string sites_fingerprint(const std::vector<const site::Site*>& sites) {
  if (sites.size() == 1) return sites.front()->fingerprint();
  std::string fp = "sites:";
  for (std::size_t s = 0; s < sites.size(); ++s) fp += (s ? "," : "") + sites[s]->fingerprint();
  return fp;
}

std::vector<records::WimRecord> merge_site_records(std::vector<std::vector<records::WimRecord>> per_site) {
  struct Slot {
    std::size_t k, n, site;
  };
  std::vector<Slot> order;
  for (std::size_t s = 0; s < per_site.size(); ++s) {
    for (std::size_t k = 0; k < per_site[s].size(); ++k) order.push_back({k, per_site[s].size(), s});
  }
  // k_a / n_a < k_b / n_b in integers (no rounding: a log holds far fewer than 2^32 records, so the
  // products fit in 64 bits), then the site's order.
  std::stable_sort(order.begin(), order.end(), [](const Slot& a, const Slot& b) {
    const std::uint64_t lhs = std::uint64_t{a.k} * b.n, rhs = std::uint64_t{b.k} * a.n;
    return lhs != rhs ? lhs < rhs : a.site < b.site;
  });
  std::vector<records::WimRecord> out;
  out.reserve(order.size());
  for (const Slot& slot : order) {
    out.push_back(std::move(per_site[slot.site][slot.k]));
    out.back().site = static_cast<std::uint32_t>(slot.site);
  }
  return out;
}

PosteriorCloud cloud_at_site(const PosteriorCloud& cloud, std::size_t site) {
  const CloudSite& s = cloud.sites.at(site);
  if (s.pool_begin + s.pool_count > cloud.speed_mps.size() || cloud.speed_mps.size() != cloud.sprung_mass_kg.size()) {
    throw std::out_of_range("cloud_at_site: the site's pool lies outside the cloud's");
  }
  PosteriorCloud out = cloud;
  // A site with no trucks of its own here (one vehicle class may skip a site): every site's traffic.
  const bool own = s.pool_count > 0;
  const auto b = static_cast<std::ptrdiff_t>(s.pool_begin), e = static_cast<std::ptrdiff_t>(s.pool_begin + s.pool_count);
  if (own) {
    out.speed_mps.assign(cloud.speed_mps.begin() + b, cloud.speed_mps.begin() + e);
    out.sprung_mass_kg.assign(cloud.sprung_mass_kg.begin() + b, cloud.sprung_mass_kg.begin() + e);
  }
  // Its own trucks: a class's share at this site is its trucks there.
  out.trucks_seen = s.trucks_seen;
  out.site_fingerprint = s.fingerprint;
  out.road_name = s.road_name;
  out.sensors = s.sensors;
  out.lateral_min_m = s.lateral_min_m;
  out.lateral_max_m = s.lateral_max_m;
  out.sites.clear();
  // The site's own sensor calibration, if the fit had any.
  out.calibration.clear();
  for (const auto& c : cloud.calibration) {
    if (c.site == s.name) out.calibration.push_back(c);
  }
  return out;
}

std::size_t find_cloud_site(const PosteriorCloud& cloud, const std::string& name, const std::string& posterior_path) {
  std::string names;
  for (std::size_t s = 0; s < cloud.sites.size(); ++s) {
    if (cloud.sites[s].name == name) return s;
    names += (s ? ", " : "") + cloud.sites[s].name;
  }
  if (cloud.sites.empty()) {
    throw UsageError("--site " + name + ": the posterior in '" + posterior_path +
                     "' was fitted on one site, not on a manifest's sites");
  }
  throw UsageError("--site " + name + ": the posterior in '" + posterior_path + "' has no such site (its sites: " +
                   names + ")");
}

void remove_sensor_gains(records::WimRecord& record, const Eigen::VectorXd& gains) {
  if (gains.size() != record.impact_factor.size()) {
    throw std::invalid_argument("remove_sensor_gains: " + std::to_string(gains.size()) + " gains for " +
                                std::to_string(record.impact_factor.size()) + " sensors");
  }
  record.impact_factor.array() /= gains.array();
}

}  // namespace ssrfleet::fleet
