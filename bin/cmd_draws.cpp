// ssrfleet draws: a posterior file's equal-weight draws as CSV or as NetCDF4 in ArviZ's layout
// (docs/draws.md), for notebooks (numpy, pandas, xarray, ArviZ).
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "draws_output.hpp"
#include "fleet/equal_weight_draws.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/draws_csv.hpp"
#include "io/draws_netcdf.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

DrawsFormat draws_format(const std::string& path, const std::string& option) {
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension == ".csv") return DrawsFormat::csv;
  if (extension == ".nc") return DrawsFormat::netcdf;
  throw UsageError(option + " '" + path + "': the format follows the extension, .csv (CSV) or .nc (NetCDF4)");
}

void write_draws(const std::string& path, const fleet::PosteriorCloud& cloud, const DrawsExtras& extras) {
  const fleet::EqualWeightDraws draws = fleet::equal_weight_draws(cloud);
  if (draws_format(path, "--out") == DrawsFormat::csv) {
    write_output(path, [&](std::ostream& os) { io::write_draws_csv(os, draws, cloud.psi_names); });
    return;
  }
  const io::DrawsFileInfo info{io::iso_utc_now(), SSRFLEET_VERSION};
  if (extras.observed == nullptr) {
    io::write_draws_netcdf(path, cloud, draws, info);
    return;
  }
  const io::ObservedLog log = io::observed_log_of(*extras.observed);
  if (extras.site == nullptr || extras.predictive_draws < 1 || extras.predictive_trucks < 1) {
    io::write_draws_netcdf(path, cloud, draws, info, &log);
    return;
  }
  const auto predictive = fleet::posterior_predictive_draws(*extras.site, cloud, draws, *extras.observed,
                                                            extras.predictive_draws, extras.predictive_trucks,
                                                            extras.seed);
  io::write_draws_netcdf(path, cloud, draws, info, &log, &predictive);
}

int run_draws(int argc, const char* const argv[]) {
  std::string posterior_path, out, log_path, class_label, road, seed_text = "1";
  long predictive_draws = fleet::kPredictiveDrawsCap, predictive_trucks = fleet::kPredictiveTrucksCap;
  SiteFlags site_flags;
  bool quiet = false;
  po::options_description desc("draws options");
  desc.add_options()
      ("help,h", "show this help")
      ("posterior", po::value(&posterior_path)->value_name("PATH"), kPosteriorHelp)
      ("out,o", po::value(&out)->value_name("FILE"),
       "draws file to write: FILE.csv (one row a draw) or FILE.nc (NetCDF4, ArviZ's InferenceData groups)")
      ("log", po::value(&log_path)->value_name("WIM_LOG"),
       "the WIM log the posterior was fitted to: the NetCDF file's observed_data (if, dims truck and sensor) and "
       "constant_data (speeds and masses)")
      ("class", po::value(&class_label)->value_name("LABEL"),
       "a posterior of vehicle classes: the draws of this class (each class is its own file)")
      ("predictive-draws", po::value(&predictive_draws)->value_name("N")->default_value(predictive_draws),
       "with --log: posterior_predictive for N draws of each chain, spread evenly over it (0: none)")
      ("predictive-trucks", po::value(&predictive_trucks)->value_name("N")->default_value(predictive_trucks),
       "with --log: the posterior predictive of the log's first N trucks")
      ("road", po::value(&road)->value_name("ROAD"),
       "the fitted road, for the posterior predictive (default: the road the posterior names); with the site "
       "options below it must make the fitted site")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text),
       "random seed of the posterior predictive (a whole number)")
      ("quiet,q", po::bool_switch(&quiet), "no summary on standard error");
  site_flags.add_to(desc);
  po::positional_options_description positional;
  positional.add("posterior", 1);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, &positional, vm,
                     "ssrfleet draws POSTERIOR --out FILE.csv|FILE.nc [--log WIM_LOG] [--class LABEL]",
                     "A chain is one independent run: an SMC fit is one chain (its pooled final sweeps resampled "
                     "together), an MCMC fit has one per --chains. Each chain's weighted draws become equal-weight "
                     "ones by systematic resampling with the offset fixed at 1/2: no random numbers, so a posterior "
                     "file always gives the same draws.")) {
    return 0;
  }
  if (posterior_path.empty()) throw UsageError("draws needs a posterior: POSTERIOR (see --help)");
  if (out.empty()) throw UsageError("draws needs --out FILE.csv or FILE.nc (see --help)");
  const DrawsFormat format = draws_format(out, "--out");
  const std::uint64_t seed = parse_seed(seed_text);
  if (predictive_draws < 0 || predictive_trucks < 0 || predictive_draws > 1'000'000 || predictive_trucks > 10'000'000) {
    throw UsageError("--predictive-draws / --predictive-trucks: need 0 <= draws <= 1e6 and 0 <= trucks <= 1e7");
  }
  if (format == DrawsFormat::csv && !log_path.empty()) {
    throw UsageError("--log fills the NetCDF file's observed_data; a CSV holds the draws alone: write FILE.nc");
  }
  const fleet::ClassPosteriors classes = io::read_posterior_classes(posterior_path);
  const fleet::ClassPosterior* chosen = nullptr;
  if (fleet::unlabelled(classes)) {
    if (!class_label.empty()) throw UsageError("--class: '" + posterior_path + "' has no vehicle classes");
    chosen = &classes.front();
  } else {
    for (const auto& c : classes) {
      if (c.label == class_label) chosen = &c;
    }
    if (chosen == nullptr) {
      throw UsageError((class_label.empty() ? std::string("'" + posterior_path + "' holds vehicle classes")
                                            : "--class '" + class_label + "': '" + posterior_path + "' holds classes") +
                       " " + fleet::list_labels(classes) + ": give --class LABEL (each class is its own draws file)");
    }
  }
  const fleet::PosteriorCloud& cloud = chosen->cloud;
  std::vector<records::WimRecord> records;
  if (!log_path.empty()) {
    if (!cloud.sites.empty()) {
      throw UsageError("--log: '" + posterior_path + "' is a fit of " + std::to_string(cloud.sites.size()) +
                       " sites, whose logs differ in their sensors; write the draws without --log");
    }
    int sensors = 0;
    std::size_t header_line = 1;
    records = io::read_wim_log_file(log_path, site_flags.m1_kg, &sensors, {}, &header_line);
    if (sensors != cloud.sensors) {
      throw DataError(log_path, header_line, "if_" + std::to_string(sensors),
                      "the log has " + std::to_string(sensors) + " sensors but the posterior's site has " +
                          std::to_string(cloud.sensors));
    }
    if (!fleet::unlabelled(classes)) {
      std::erase_if(records, [&](const records::WimRecord& r) { return r.vehicle_class != chosen->label; });
    }
    if (static_cast<long>(records.size()) != cloud.trucks_seen) {
      throw DataError(log_path, 0, "truck_id",
                      "the log has " + std::to_string(records.size()) + " trucks" +
                          (chosen->label.empty() ? "" : " of class " + chosen->label) + " but the posterior absorbed " +
                          std::to_string(cloud.trucks_seen) + ": give the log it was fitted to");
    }
  }
  DrawsExtras extras;
  std::optional<site::Site> site;
  if (!log_path.empty()) {
    extras.observed = &records;
    if (format == DrawsFormat::netcdf && predictive_draws > 0 && predictive_trucks > 0) {
      site.emplace(site::load_road(road.empty() ? cloud.road_name : road, &std::cerr), site_flags.to_options());
      require_fitted_site(cloud, posterior_path, *site,
                          "; give the fit's --road and site options, or --predictive-draws 0 to leave the posterior "
                          "predictive out");
      extras.site = &*site;
    }
  }
  extras.predictive_draws = predictive_draws;
  extras.predictive_trucks = predictive_trucks;
  extras.seed = seed;
  write_draws(out, cloud, extras);
  if (!quiet) {
    const int chains = cloud.method == "mcmc" ? cloud.chains : 1;
    std::cerr << "ssrfleet draws: " << chains << (chains == 1 ? " chain" : " chains") << " x "
              << cloud.theta.cols() / chains << " draws (" << cloud.method << ", model " << cloud.model << ")"
              << (records.empty() ? "" : ", " + std::to_string(records.size()) + " observed trucks") << " -> " << out
              << "\n";
  }
  return 0;
}

}  // namespace ssrfleet::cli
