// The draws file that `draws --out` and `fit --draws-out` write (docs/draws.md): CSV or NetCDF4 in
// ArviZ's layout, chosen by the path's extension.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fleet/posterior_cloud.hpp"
#include "fleet/posterior_predictive_draws.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::cli {

enum class DrawsFormat { csv, netcdf };

// ".csv" or ".nc"; anything else (or an empty path) is a UsageError naming `option`.
DrawsFormat draws_format(const std::string& path, const std::string& option);

// What goes beside the draws in a NetCDF file (the CSV holds the draws alone).
struct DrawsExtras {
  const std::vector<records::WimRecord>* observed = nullptr;  // the fitted log: observed_data, constant_data
  // With the log, the site it was fitted on: posterior_predictive for the first predictive_draws
  // draws of each chain (spread evenly) x the first predictive_trucks trucks; null or a cap of 0: none.
  const site::Site* site = nullptr;
  long predictive_draws = fleet::kPredictiveDrawsCap, predictive_trucks = fleet::kPredictiveTrucksCap;
  std::uint64_t seed = 1;  // the predictive's trucks and noise
};

// The cloud's equal-weight draws to `path`.
void write_draws(const std::string& path, const fleet::PosteriorCloud& cloud, const DrawsExtras& extras = {});

}  // namespace ssrfleet::cli
