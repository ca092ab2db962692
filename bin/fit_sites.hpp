// `fit --sites MANIFEST` without --site: one fleet posterior from every site of a manifest
// (docs/sites.md). Each site keeps its own road, sensor array and log; the fleet's hyperparameters
// are shared; the marginal core fits all the trucks at once, each through its own site.
#pragma once

#include <cstdint>
#include <string>

#include "cli_common.hpp"
#include "discrepancy/sensor_calibration.hpp"
#include "fit_methods.hpp"

namespace ssrfleet::cli {

struct JointFitRequest {
  std::string manifest_path;
  std::string out;
  std::string method;  // only "smc" fits several sites
  std::uint64_t seed = 1;
  bool quiet = false;
  // Fit each site's sensor gains beside the fleet (docs/sites.md): Monte Carlo EM,
  // at most `calibration_rounds` fits, starting from the manifest's calibrations.
  bool calibrate = false;
  int calibration_rounds = discrepancy::CalibrationOptions{}.max_rounds;
  // With calibrate: a copy of the manifest with each site's fitted gains as its calibration (paths
  // made absolute), for a stream (`stream --sites`) that goes on from the batch fit. "" = none.
  std::string calibrated_manifest;
};

// Reads the manifest, every site's road and log (errors name the manifest, the site and the field,
// or the log's file, line and field), fits, writes the posterior file (its site.sites lists the
// sites by name). One class per vehicle class of the logs, as `fit` does for one site. A site's
// calibration (the manifest's, or fitted with request.calibrate) is divided out of its records and
// recorded in the posterior's "calibration".
void fit_manifest_sites(const JointFitRequest& request, const FitFlags& fit, const SiteFlags& site_flags,
                        const io::WimLimits& limits);

}  // namespace ssrfleet::cli
