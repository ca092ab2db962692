// ssrfleet weigh: each truck's static wheel load from its raw tyre forces, corrected for the site's
// SSR by the fleet posterior (weigh/static_weight.hpp has the estimator, the
// fixed point over the unknown sprung mass, and the interval).
#include <iostream>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/force_log.hpp"
#include "io/posterior_json.hpp"
#include "io/site_manifest.hpp"
#include "io/static_weights_csv.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"
#include "weigh/static_weight.hpp"

namespace ssrfleet::cli {

int run_weigh(int argc, const char* const argv[]) {
  std::string log_path, posterior_path, road = "AS1", out = "-", seed_text = "1", class_label;
  bool quiet = false;
  weigh::WeighOptions options;
  SiteFlags site_flags;
  SiteChoice where;
  po::options_description desc("weigh options");
  desc.add_options()
      ("help,h", "show this help")
      ("log", po::value(&log_path)->value_name("FILE")->required(),
       "force log (CSV; positional: FORCES): truck_id, time_s (optional), speed_mps, force_1..force_M (N, one per "
       "sensor); a sprung_mass_kg column may be there and is not used")
      ("posterior", po::value(&posterior_path)->value_name("PATH")->required(), kPosteriorHelp)
      ("road", po::value(&road)->value_name("ROAD")->default_value(road),
       "the road the posterior was fitted on: preset AS1, AS2 or AS3, or a road file (a road CSV or an OpenCRG .crg "
       "surface; the kind is read from the file's content)")
      ("draws", po::value(&options.prediction.theta_draws)->value_name("N")->default_value(options.prediction.theta_draws),
       "posterior draws of theta per predicted IF pattern")
      ("trucks-per-draw",
       po::value(&options.prediction.trucks_per_draw)->value_name("N")->default_value(options.prediction.trucks_per_draw),
       "simulated trucks per theta draw (their spread gives the IF covariance)")
      ("tolerance", po::value(&options.relative_tolerance)->value_name("X")->default_value(options.relative_tolerance, "1e-6"),
       "fixed point: stop when a step moves the estimate by less than this fraction")
      ("max-iterations", po::value(&options.max_iterations)->value_name("N")->default_value(options.max_iterations),
       "fixed point: give up (an error) after this many steps")
      ("class", po::value(&class_label)->value_name("LABEL"),
       "a posterior of vehicle classes: weigh every truck as one of this class (needed when it holds several)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text),
       "random seed (a whole number; the same draws for every truck and step)")
      ("out,o", po::value(&out)->value_name("FILE")->default_value(out), "weights CSV to write ('-' = standard output)")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  where.add_to(desc);
  site_flags.add_to(desc);
  po::positional_options_description positional;
  positional.add("log", 1);
  refuse_options(argc, argv, {{"--state", "give a stream's state directory with --posterior DIR"}});
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, &positional, vm,
                     "ssrfleet weigh FORCES --posterior PATH [--road ROAD | --sites MANIFEST --site NAME] [--out FILE]",
                     "The road and the site options must be those the posterior was fitted with.")) {
    return 0;
  }
  options.prediction.seed = parse_seed(seed_text);
  options.validate();
  // The site first: a malformed --sites/--site is named before the posterior is read.
  const site::Site site = where.site(road, vm, site_flags);
  fleet::ClassPosteriors classes = select_posterior_classes(posterior_path, class_label, "", where.site_name).classes;
  if (classes.size() > 1) {
    throw UsageError("the posterior in '" + posterior_path + "' holds vehicle classes " + fleet::list_labels(classes) +
                     ": pick the trucks' class with --class");
  }
  const fleet::PosteriorCloud& cloud = classes.front().cloud;
  require_fitted_site(cloud, posterior_path, site, "; weigh needs the road and site options the posterior was fitted with");
  auto records = io::read_force_log_file(log_path, site.sensors(), "(--sensors " + site_flags.sensors + ")");
  // A site whose sensors the fit calibrated (docs/sites.md): its forces read gain x the
  // true ones, which is divided out here as the fit divided it out of the impact factors. The gains
  // are the posterior's (the manifest's as the fit read them, or fitted); a manifest that calibrates
  // the site beside a posterior fitted without would correct the forces and not the fleet: refused.
  if (!where.site_name.empty() && cloud.calibration.empty() &&
      !io::read_site_manifest(where.manifest_path).find(where.site_name).calibration.empty()) {
    throw UsageError("site '" + where.site_name + "' has a calibration in the manifest '" + where.manifest_path +
                     "', but the posterior in '" + posterior_path + "' was fitted without one: fit it again with "
                     "this manifest");
  }
  if (cloud.calibration.size() == 1) {
    const std::vector<double>& gain = cloud.calibration.front().gain;
    if (gain.size() != static_cast<std::size_t>(site.sensors())) {
      throw DataError(posterior_path, 0, "calibration", "site '" + cloud.calibration.front().site + "' has " +
                                                            std::to_string(gain.size()) + " gains for " +
                                                            std::to_string(site.sensors()) + " sensors");
    }
    const Eigen::Map<const Eigen::ArrayXd> g(gain.data(), static_cast<Eigen::Index>(gain.size()));
    for (auto& r : records) r.force_n.array() /= g;
    if (!quiet) std::cerr << "ssrfleet weigh: the site's sensor calibration from the posterior is divided out of the forces\n";
  }

  std::vector<records::StaticWeight> weights;
  weights.reserve(records.size());
  long steps = 0;
  for (const auto& record : records) {
    weights.push_back(weigh::estimate_static_weight(cloud, site, record, log_path, options));
    steps += weights.back().iterations;
    if (!quiet && (weights.size() % 100 == 0 || weights.size() == records.size())) {
      std::cerr << "ssrfleet weigh: truck " << weights.size() << "/" << records.size() << "\n";
    }
  }
  write_output(out, [&](std::ostream& os) { io::write_static_weights_csv(os, weights); });
  if (!quiet) {
    std::cerr << "ssrfleet weigh: " << weights.size() << " trucks, " << static_cast<double>(steps) / static_cast<double>(weights.size())
              << " fixed-point steps per truck on average, posterior of " << cloud.trucks_seen << " trucks on road "
              << site.surface().name << "\n";
  }
  return 0;
}

}  // namespace ssrfleet::cli
