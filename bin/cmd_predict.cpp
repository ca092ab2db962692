// ssrfleet predict: the SSR prediction (mean IF, 95 % prediction limits, 95 % band of the mean
// pattern) from a posterior file, at the sensors or any positions, on the fitted road or another.
#include <iostream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fleet/joint_sites.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/site_manifest.hpp"
#include "io/posterior_json.hpp"
#include "predict/ssr_prediction.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {


int run_predict(int argc, const char* const argv[]) {
  std::string posterior_path, road = "AS1", out = "-", positions, seed_text = "1", class_label, mix_text;
  SiteChoice where;
  bool new_road = false, quiet = false, fixed_traffic = false;
  predict::PredictionOptions options;
  SiteFlags site_flags;
  po::options_description desc("predict options");
  desc.add_options()
      ("help,h", "show this help")
      ("posterior", po::value(&posterior_path)->value_name("PATH")->required(), kPosteriorHelp)
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("new-road", po::bool_switch(&new_road), "predict on a site other than the fitted one (paper Fig. 9)")
      ("positions", po::value(&positions)->value_name("LIST"),
       "where to predict: positions along the road (m) as a list 'a,b,c' or FIRST:STEP:LAST (default: the sensors)")
      ("draws", po::value(&options.theta_draws)->value_name("N")->default_value(options.theta_draws),
       "posterior draws of theta")
      ("trucks-per-draw", po::value(&options.trucks_per_draw)->value_name("N")->default_value(options.trucks_per_draw),
       "simulated trucks per theta draw (stratified: a Latin hypercube over the observed truck, k, k_t, z)")
      ("fixed-traffic", po::bool_switch(&fixed_traffic),
       "take the observed trucks' speeds and masses as the traffic itself: the band of the mean then shows "
       "theta's uncertainty only (default: a Bayesian bootstrap of them adds the uncertainty of the traffic mix)")
      ("class", po::value(&class_label)->value_name("LABEL"), "a posterior of vehicle classes: predict this class alone")
      ("mix", po::value(&mix_text)->value_name("SHARES"),
       "a posterior of vehicle classes: combine them in these traffic shares, e.g. A=0.7,B=0.3 (each >= 0, summing to "
       "1; a class left out has share 0; default: each class's observed share)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text), "random seed (a whole number)")
      ("out,o", po::value(&out)->value_name("FILE")->default_value(out), "prediction CSV to write ('-' = standard output)")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  where.add_to(desc);
  site_flags.add_to(desc);
  refuse_options(argc, argv, {{"--state", "give a stream's state directory with --posterior DIR"}});
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet predict --posterior PATH [--road ROAD | --sites MANIFEST --site NAME] [--new-road] "
                     "[--positions LIST] [--out FILE]")) {
    return 0;
  }
  options.seed = parse_seed(seed_text);
  options.traffic_bootstrap = !fixed_traffic;
  // The site first: a malformed --sites/--site is named before the posterior is read.
  const site::Site site = where.site(road, vm, site_flags);
  // A posterior of several sites seen from the site asked for: its own traffic, class shares and
  // fingerprint.
  const ClassSelection selection = select_posterior_classes(posterior_path, class_label, mix_text, where.site_name);
  const fleet::ClassPosteriors& classes = selection.classes;
  const std::vector<double>& shares = selection.shares;
  const fleet::PosteriorCloud& cloud = classes.front().cloud;
  if (!new_road) {
    require_fitted_site(cloud, posterior_path, site, "; pass --new-road to predict for a different road on purpose");
  }
  const auto prediction = predict::predict_ssr_mixture(classes, shares, site, parse_positions(positions), options);
  write_output(out, [&](std::ostream& os) { predict::write_prediction_csv(os, prediction); });
  if (!quiet) {
    long total_trucks = 0;
    for (const auto& c : classes) total_trucks += c.cloud.trucks_seen;
    std::cerr << "ssrfleet predict: " << prediction.position_m.size() << " positions on road " << site.surface().name
              << " from " << total_trucks << " trucks (" << cloud.method << ", model " << cloud.model << "), "
              << options.theta_draws * options.trucks_per_draw << " simulated passes";
    if (!fleet::unlabelled(classes)) {
      std::cerr << " per class; classes";
      for (std::size_t c = 0; c < classes.size(); ++c) {
        std::cerr << " " << classes[c].label << " (" << classes[c].cloud.trucks_seen << " trucks, share " << shares[c] << ")";
      }
    }
    std::cerr << "\n";
  }
  return 0;
}

}  // namespace ssrfleet::cli
