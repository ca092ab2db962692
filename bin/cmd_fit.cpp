// ssrfleet fit: offline replay of a WIM log through the tempered SMC (default) or the paper's
// batch MCMC; writes the posterior file (summary + draws) that `predict` reads.
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "draws_output.hpp"
#include "fit_methods.hpp"
#include "fit_sites.hpp"
#include "process_ranks.hpp"
#include "io/wim_log.hpp"
#include "model/model_spec.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

int run_fit(int argc, const char* const argv[]) {
  std::string log_path, road = "AS1", out = "posterior.json", seed_text = "1", method = "smc", manifest_path, site_name;
  FitFlags fit;
  bool quiet = false, fhwa = false, calibrate = false;
  int calibration_rounds = discrepancy::CalibrationOptions{}.max_rounds;
  std::string calibrated_manifest, draws_out;
  SiteFlags site_flags;
  po::options_description desc("fit options");
  desc.add_options()
      ("help,h", "show this help")
      ("log", po::value(&log_path)->value_name("FILE"), "WIM log (CSV) to replay (positional: LOG)")
      ("sites", po::value(&manifest_path)->value_name("MANIFEST"),
       "a site manifest (JSON: each site's name, road, sensors and log): one fleet posterior from all its sites; "
       "with --site, fit that site alone")
      ("site", po::value(&site_name)->value_name("NAME"),
       "the manifest's site to fit (its log, road and sensors from the manifest)")
      ("calibrate", po::bool_switch(&calibrate),
       "with --sites: fit each site's sensor gains beside the fleet (Monte Carlo EM, starting from the manifest's "
       "calibration)")
      ("calibration-rounds", po::value(&calibration_rounds)->value_name("N")->default_value(calibration_rounds),
       "with --calibrate: the most fits the EM runs (it stops when no gain moves by 0.3 of its standard error)")
      ("write-manifest", po::value(&calibrated_manifest)->value_name("FILE"),
       "with --calibrate: write the manifest again with each site's fitted gains as its calibration (paths made "
       "absolute), for stream --sites")
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("out,o", po::value(&out)->value_name("FILE")->default_value(out), "posterior file to write (JSON; '-' = standard output)")
      ("draws-out", po::value(&draws_out)->value_name("FILE"),
       "also write the posterior's equal-weight draws: FILE.csv, or FILE.nc (NetCDF4 in ArviZ's layout, with the log "
       "as observed_data); ssrfleet draws --help says how")
      ("method", po::value(&method)->value_name("METHOD")->default_value(method),
       "smc (sequential, default) or mcmc (the paper's batch baseline)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text), "random seed (a whole number)")
      ("fhwa-classes", po::bool_switch(&fhwa),
       "the log's class column must hold FHWA vehicle classes 1..13 (otherwise any label of A-Z a-z 0-9 _ . -)")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  fit.add_to(desc);
  site_flags.add_to(desc);
  po::positional_options_description positional;
  positional.add("log", 1);
  po::variables_map vm;
  refuse_options(argc, argv, {{"--window", "the default (marginal) core keeps its memory per truck flat and needs no "
                                           "window: drop --window"}});
  if (!parse_or_help(argc, argv, desc, &positional, vm,
                     "ssrfleet fit LOG [--road ROAD] [--model SPEC] [--out FILE] [--particles N] [--seed SEED]\n"
                     "ssrfleet fit --sites MANIFEST [--site NAME] [--calibrate] [--out FILE] [...]",
                     "A log with a class column gets one posterior per vehicle class, all in the one file. The model "
                     "spec and the effects it can name: ssrfleet effects.")) {
    return 0;
  }
  check_particles(fit.particles);
  // Rank 0 reports for every rank (another rank's progress would pile up unseen: main() drops it).
  quiet = quiet || process_ranks().rank() != 0;
  fit.final_sweeps_given = !vm["final-sweeps"].defaulted();
  fit.max_sweeps_given = !vm["max-sweeps"].defaulted();
  fit.core_given = !vm["core"].defaulted();
  const std::uint64_t seed = parse_seed(seed_text);
  if (!draws_out.empty()) draws_format(draws_out, "--draws-out");
  if (method != "smc" && method != "mcmc") throw UsageError("--method '" + method + "': must be smc or mcmc");
  if (method == "mcmc" && !vm["runs"].defaulted()) {
    throw UsageError("--runs repeats the SMC; the batch MCMC's independent runs are its --chains");
  }
  if (method == "smc" && !vm["chains"].defaulted()) {
    throw UsageError("--chains are the batch MCMC's (--method mcmc); the SMC's independent runs are --runs");
  }
  if (method == "mcmc" && !fit.checkpoint_dir.empty()) {
    throw UsageError("--checkpoint: checkpoints are the SMC's (a batch MCMC chain is not resumed); drop --method mcmc");
  }
  if (method == "mcmc" && process_ranks().size() > 1) {
    throw UsageError("--method mcmc runs on one process; only the SMC's marginal core spreads over MPI ranks");
  }

  if (!calibrate && !calibrated_manifest.empty()) throw UsageError("--write-manifest writes fitted gains: add --calibrate");
  if (!calibrate && !vm["calibration-rounds"].defaulted()) throw UsageError("--calibration-rounds needs --calibrate");

  io::WimLimits limits;
  limits.fhwa_classes = fhwa;
  // A site of a manifest brings its own log, road and sensors; the vehicle constants stay options.
  std::optional<io::SiteManifest> manifest;
  const io::ManifestSite* entry = nullptr;
  if (!manifest_path.empty()) {
    refuse_beside_sites(vm, {"log", "road", "sensors"});
    if (site_name.empty()) {
      if (!draws_out.empty()) {
        throw UsageError("--draws-out: a fit of a manifest's sites together writes its posterior only; then run "
                         "ssrfleet draws POSTERIOR --out FILE (or fit one site: --site NAME)");
      }
      if (calibration_rounds < 1) throw UsageError("--calibration-rounds must be at least 1");
      fit_manifest_sites({manifest_path, out, method, seed, quiet, calibrate, calibration_rounds, calibrated_manifest}, fit,
                         site_flags, limits);
      return 0;
    }
    if (calibrate) {
      throw UsageError("--calibrate fits the sensors of every site of the manifest at once; drop --site (a manifest "
                       "that lists one site calibrates that site alone)");
    }
    manifest = io::read_site_manifest(manifest_path);
    entry = &manifest->find(site_name);
    log_path = entry->log;
  } else if (calibrate) {
    throw UsageError("--calibrate needs --sites MANIFEST (the sites whose sensors it calibrates)");
  } else if (!site_name.empty()) {
    throw UsageError("--site names a site of a manifest: give the manifest with --sites");
  } else if (log_path.empty()) {
    throw UsageError("fit needs a WIM log: LOG, or --sites MANIFEST --site NAME (see --help)");
  }
  const site::Site site = entry != nullptr ? site_of_manifest_entry(*manifest, *entry, site_flags, &std::cerr)
                                           : site::Site(site::load_road(road, &std::cerr), site_flags.to_options());
  const fleet::ModelSpec model = fleet::parse_model_spec(fit.model, site);
  const auto records = entry != nullptr ? read_manifest_site_log(*manifest, *entry, site, site_flags, limits)
                                        : read_site_log(log_path, site, site_flags, limits);
  if (!quiet) {
    std::cerr << "ssrfleet fit: " << records.size() << " trucks from " << log_path << ", road " << site.surface().name
              << ", method " << method << ", model " << model.text << ", seed " << seed << "\n";
  }
  if (!draws_out.empty() && fleet::split_by_class(records).size() > 1) {
    throw UsageError("--draws-out: the log has several vehicle classes, each its own posterior; fit, then write each "
                     "class's draws with ssrfleet draws POSTERIOR --class LABEL --out FILE");
  }
  const auto start = std::chrono::steady_clock::now();
  std::ostream* progress = quiet ? nullptr : &std::cerr;
  const fleet::ClassPosteriors classes = fit_classes_to_file(records, seed, out, quiet ? nullptr : &std::cerr,
                      [&](const std::vector<records::WimRecord>& class_records, std::uint64_t class_seed) {
                        fleet::PosteriorCloud cloud =
                            method == "smc"
                                ? fit_smc(site, class_records, fit, class_seed, progress, model.extension.get())
                                : fit_mcmc(site, class_records, fit, class_seed, progress, model.extension.get());
                        // The manifest's calibration was divided out of the records (read_manifest_site_log).
                        if (entry != nullptr && !entry->calibration.empty()) {
                          cloud.calibration = {{entry->name, entry->calibration, {}}};
                        }
                        return cloud;
                      });
  // Rank 0 writes for every rank (the ranks hold the same posterior).
  if (!draws_out.empty() && process_ranks().rank() == 0) {
    DrawsExtras extras;
    extras.observed = &records;
    extras.site = &site;
    extras.seed = seed;
    write_draws(draws_out, classes.front().cloud, extras);
  }
  if (!quiet) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cerr << "ssrfleet fit: done in " << std::fixed << std::setprecision(1) << s << " s -> " << out
              << (draws_out.empty() ? "" : ", draws -> " + draws_out) << "\n";
  }
  return 0;
}

}  // namespace ssrfleet::cli
