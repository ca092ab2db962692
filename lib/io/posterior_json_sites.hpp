// The sites of a posterior file written by a fit over several sites, and their sensor calibration
// (posterior_cloud.hpp: CloudSite, SiteCalibration): reading and checking them, every error naming
// the file and the field.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "fleet/posterior_cloud.hpp"

namespace ssrfleet::io {

// `sites` at `where`, after the cloud's pool is read: each site's pool a range of it, the ranges in
// order and covering it, the names distinct. Fills c.sites.
void parse_posterior_sites(const nlohmann::json& sites, const std::string& path, const std::string& where,
                           fleet::PosteriorCloud& c);
// `list` at `where`: per site its name, its gains (positive) and, if they were fitted, their
// standard errors (one per gain, >= 0). Fills c.calibration.
void parse_posterior_calibration(const nlohmann::json& list, const std::string& path,
                                 const std::string& where, fleet::PosteriorCloud& c);

}  // namespace ssrfleet::io
