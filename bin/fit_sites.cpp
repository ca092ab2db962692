#include "fit_sites.hpp"

#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>

#include "fleet/joint_sites.hpp"
#include "io/site_manifest.hpp"
#include "process_ranks.hpp"
#include "road/surface_presets.hpp"
#include "smc/engine.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {

// fit --calibrate: the sites' sensor gains by Monte Carlo EM (discrepancy/sensor_calibration.hpp).
// `records` come in with the manifest's calibration divided out and leave with the fitted gains
// divided out too; `calibration` leaves with each site's whole gains (manifest's x fitted) and their
// standard errors. Returns the EM's last fit's posterior: the fit of the records as they leave.
fleet::PosteriorCloud calibrate_sensors(const JointFitRequest& request, const FitFlags& fit, const io::SiteManifest& manifest,
                       const std::vector<const site::Site*>& sites, std::vector<records::WimRecord>& records,
                       std::vector<fleet::SiteCalibration>& calibration, std::ostream* progress) {
  for (const auto& r : records) {
    if (!r.vehicle_class.empty()) {
      throw UsageError("--calibrate: the logs have a class column; a sensor's gain is the site's, not a class's, "
                       "and one fleet model of every class would bias it: calibrate on an unlabelled log");
    }
  }
  if (process_ranks().size() > 1) {
    throw UsageError("--calibrate runs on one process: its latent draws need every truck's table (drop mpirun, or "
                     "fit the gains first and give them to the ranks' fit in the manifest's calibration)");
  }
  if (fit.runs > 1) {
    throw UsageError("--runs with --calibrate: the EM refits the corrected data round after round, one run each; "
                     "check the final posterior's Monte Carlo error with fit --runs on the calibrated manifest");
  }
  if (!fit.checkpoint_dir.empty()) {
    throw UsageError("--checkpoint with --calibrate: each round refits corrected data, which a checkpoint of the "
                     "first round does not hold; drop one of them");
  }
  discrepancy::CalibrationOptions o;
  o.max_rounds = request.calibration_rounds;
  o.draws.seed = request.seed;
  o.draws.threads = fit.threads > 0 ? fit.threads : smc::TemperedSampler::Options::default_threads();
  std::vector<Eigen::VectorXd> ones;
  for (const site::Site* s : sites) ones.push_back(Eigen::VectorXd::Ones(s->sensors()));
  // The rounds' fits report only their end: a fit per round would bury the rounds' lines.
  const auto fit_round = [&](const std::vector<records::WimRecord>& corrected) {
    return fit_smc_online(sites, corrected, fit, request.seed, nullptr);
  };
  const auto report = [&](int round, const discrepancy::CalibrationRound& r) {
    if (!progress) return;
    *progress << "ssrfleet fit: calibration round " << round << ": largest gain step " << std::fixed
              << std::setprecision(2) << r.largest_step_se << " standard errors (converged below " << o.tolerance_se
              << ")\n";
    progress->unsetf(std::ios::floatfield);
  };
  if (progress) {
    *progress << "ssrfleet fit: calibrating the sites' sensors (Monte Carlo EM, at most " << o.max_rounds
              << " fits of " << records.size() << " trucks) ...\n";
  }
  const discrepancy::CalibratedFit done = discrepancy::fit_with_sensor_calibration(records, ones, fit_round, o, report);
  for (auto& r : records) fleet::remove_sensor_gains(r, done.gains[r.site]);
  for (std::size_t s = 0; s < sites.size(); ++s) {
    auto& c = calibration[s];
    c.se.assign(c.gain.size(), 0.0);
    for (std::size_t j = 0; j < c.gain.size(); ++j) {
      const auto k = static_cast<Eigen::Index>(j);
      c.se[j] = c.gain[j] * done.se[s][k];
      c.gain[j] *= done.gains[s][k];
    }
    if (progress) {
      *progress << "ssrfleet fit: site " << manifest.sites[s].name << " sensor gains:" << std::fixed << std::setprecision(4);
      for (std::size_t j = 0; j < c.gain.size(); ++j) *progress << " " << c.gain[j] << "±" << c.se[j];
      *progress << "\n";
      progress->unsetf(std::ios::floatfield);
    }
  }
  if (!done.converged) {
    std::cerr << "ssrfleet fit: warning: the sensor calibration had not converged after " << done.rounds.size()
              << " fits (largest last step " << done.rounds.back().largest_step_se
              << " standard errors); raise --calibration-rounds\n";
  }
  return done.fit->cloud();
}

// --write-manifest: the manifest with the fitted gains, its paths absolute (it may go to any folder).
void write_calibrated_manifest(const std::string& path, io::SiteManifest manifest,
                               const std::vector<fleet::SiteCalibration>& calibration) {
  namespace fs = std::filesystem;
  for (std::size_t s = 0; s < manifest.sites.size(); ++s) {
    io::ManifestSite& site = manifest.sites[s];
    if (!road::is_preset_name(site.road)) site.road = fs::absolute(site.road).lexically_normal().string();
    if (!site.log.empty()) site.log = fs::absolute(site.log).lexically_normal().string();
    site.calibration = calibration[s].gain;
    for (std::size_t j = 0; j < site.calibration.size(); ++j) {
      const double g = site.calibration[j];
      if (!(g >= io::kMinCalibrationGain && g <= io::kMaxCalibrationGain)) {
        throw DataError(path, 0, io::SiteManifest::field(site, "calibration") + "[" + std::to_string(j) + "]",
                        "site '" + site.name + "': the fitted gain " + std::to_string(g) + " of sensor " +
                            std::to_string(j + 1) + " is outside [0.5, 2], which a manifest does not hold; the "
                            "posterior was written, the manifest was not (check that sensor)");
      }
    }
  }
  io::write_site_manifest(path, manifest);
}

}  // namespace

void fit_manifest_sites(const JointFitRequest& request, const FitFlags& fit, const SiteFlags& site_flags,
                        const io::WimLimits& limits) {
  if (request.method != "smc") {
    throw UsageError("--sites without --site fits every site at once on the SMC's marginal core; the batch MCMC "
                     "(--method mcmc) fits one site: add --site NAME");
  }
  if (fit.model != "base") {
    throw UsageError("--model " + fit.model + " with --sites: a fit of several sites fits the base model (effects "
                     "fit one site); fit a site alone with --site NAME");
  }
  const io::SiteManifest manifest = io::read_site_manifest(request.manifest_path);
  std::ostream* progress = request.quiet ? nullptr : &std::cerr;
  const ManifestSites sites = build_manifest_sites(manifest, site_flags, &std::cerr);
  const std::vector<const site::Site*> site_ptrs = sites.pointers();
  std::vector<std::vector<records::WimRecord>> per_site;
  for (std::size_t s = 0; s < manifest.sites.size(); ++s) {
    const io::ManifestSite& entry = manifest.sites[s];
    per_site.push_back(read_manifest_site_log(manifest, entry, *site_ptrs[s], sites.flags[s], limits));
    // Ids are per site (the same id at two sites is two trucks): kept as SITE:ID, as a stream does.
    for (auto& r : per_site.back()) r.truck_id = entry.name + ":" + r.truck_id;
    if (progress) {
      *progress << "ssrfleet fit: site " << entry.name << ": " << per_site.back().size() << " trucks from "
                << entry.log << ", road " << site_ptrs[s]->surface().name << ", " << site_ptrs[s]->sensors()
                << " sensors\n";
    }
  }
  std::vector<records::WimRecord> records = fleet::merge_site_records(std::move(per_site));
  if (progress) {
    *progress << "ssrfleet fit: " << records.size() << " trucks from " << manifest.sites.size()
              << " sites of manifest " << manifest.path << ", one fleet, method smc (marginal core), seed "
              << request.seed << "\n";
  }
  const auto start = std::chrono::steady_clock::now();
  // The calibration the posterior records: the manifest's (known), replaced by the fitted one.
  std::vector<fleet::SiteCalibration> calibration;
  bool any_known = false;
  for (std::size_t s = 0; s < manifest.sites.size(); ++s) {
    const Eigen::VectorXd g = manifest_sensor_gains(manifest.sites[s], site_ptrs[s]->sensors());
    calibration.push_back({manifest.sites[s].name, std::vector<double>(g.data(), g.data() + g.size()), {}});
    any_known = any_known || !manifest.sites[s].calibration.empty();
  }
  // With --calibrate the EM's last fit is the posterior (the log has no classes: one fit, the seed's).
  std::optional<fleet::PosteriorCloud> calibrated;
  if (request.calibrate) {
    calibrated = calibrate_sensors(request, fit, manifest, site_ptrs, records, calibration, progress);
  } else if (!any_known) {
    calibration.clear();
  }
  fit_classes_to_file(records, request.seed, request.out, progress,
                      [&](const std::vector<records::WimRecord>& class_records, std::uint64_t class_seed) {
                        fleet::PosteriorCloud cloud = calibrated && class_seed == request.seed &&
                                                              class_records.size() == records.size()
                                                          ? std::move(*calibrated)
                                                          : fit_smc(site_ptrs, class_records, fit, class_seed, progress);
                        for (std::size_t s = 0; s < cloud.sites.size(); ++s) cloud.sites[s].name = manifest.sites[s].name;
                        cloud.calibration = calibration;
                        return cloud;
                      });
  if (request.calibrate && !request.calibrated_manifest.empty()) {
    write_calibrated_manifest(request.calibrated_manifest, manifest, calibration);
    if (progress) *progress << "ssrfleet fit: the manifest with the fitted gains -> " << request.calibrated_manifest << "\n";
  }
  if (progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    *progress << "ssrfleet fit: done in " << std::fixed << std::setprecision(1) << s << " s -> " << request.out << "\n";
  }
}

}  // namespace ssrfleet::cli
