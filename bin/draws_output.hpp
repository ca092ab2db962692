// The draws file that `draws --out` and `fit --draws-out` write (docs/draws.md): CSV or NetCDF4 in
// ArviZ's layout, chosen by the path's extension.
#pragma once

#include <string>
#include <vector>

#include "fleet/posterior_cloud.hpp"
#include "records/wim_record.hpp"

namespace ssrfleet::cli {

enum class DrawsFormat { csv, netcdf };

// ".csv" or ".nc"; anything else (or an empty path) is a UsageError naming `option`.
DrawsFormat draws_format(const std::string& path, const std::string& option);

// The cloud's equal-weight draws to `path`; `observed`: the fitted log's records (the NetCDF file's
// observed_data and constant_data; null leaves them out, and the CSV never has them).
void write_draws(const std::string& path, const fleet::PosteriorCloud& cloud,
                 const std::vector<records::WimRecord>* observed);

}  // namespace ssrfleet::cli
