// ssrfleet damage: where the fleet damages the pavement. From a posterior file or
// a stream's state directory: the damage amplification a_n = E[IF^n] (n = 1, 4, any further n),
// the DLC, hot spots and the expected damage per million trucks in equivalent standard axles, at
// the sensors or any positions; CSV, and a PNG along the road when asked.
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "damage/damage_profile.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/damage_csv.hpp"
#include "io/gnuplot_runner.hpp"
#include "io/posterior_json.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {
// The plot: the CSV is written beside the PNG as NAME.csv (when --out is standard output) or read
// where --out put it; the script NAME.gp stays beside the PNG so it can be re-run.
void plot_damage(const std::string& png, const std::string& csv_out, const records::DamageProfile& profile, bool quiet) {
  namespace fs = std::filesystem;
  const fs::path png_path = fs::absolute(png);
  if (png_path.extension() != ".png") throw UsageError("--png '" + png + "': the file name must end in .png");
  const std::string dir = png_path.parent_path().string(), name = png_path.stem().string();
  std::string csv = csv_out;
  if (csv.empty() || csv == "-") {
    csv = (png_path.parent_path() / (name + ".csv")).string();
    write_output(csv, [&](std::ostream& os) { io::write_damage_csv(os, profile); });
  }
  const io::PlotScript script{name, io::png_and_svg_script(name, io::damage_plot_body(fs::absolute(csv).string(), profile))};
  write_output((png_path.parent_path() / (name + ".gp")).string(), [&](std::ostream& os) { os << script.script; });
  if (!io::gnuplot_available()) {
    std::cerr << "ssrfleet damage: warning: gnuplot is not on PATH: no PNG written; run `gnuplot " << name << ".gp` in "
              << dir << " once it is installed\n";
    return;
  }
  const auto failed = io::run_gnuplot(dir, {script});
  if (!failed.empty()) throw IoError("gnuplot failed on " + dir + "/" + name + ".gp (see " + name + ".gnuplot.log there)");
  if (!quiet) std::cerr << "ssrfleet damage: plot " << png_path.string() << "\n";
}

// The damage in equivalent standard axles, for the summary: static, along the road, the worst position.
void print_summary(std::ostream& os, const records::DamageProfile& p) {
  std::size_t worst = 0, hot = 0;
  double sum = 0.0;
  for (std::size_t m = 0; m < p.position_m.size(); ++m) {
    sum += p.esal_per_million[m];
    if (p.esal_per_million[m] > p.esal_per_million[worst]) worst = m;
    hot += p.hot_spot[m] ? 1 : 0;
  }
  os << "expected damage per million trucks (ESAL: axle = 2 x wheel load, standard axle 80 kN, fourth power)\n"
     << "  static (no dynamics):       " << p.static_esal_per_million << "\n"
     << "  dynamic, mean of positions: " << sum / static_cast<double>(p.position_m.size()) << "\n"
     << "  dynamic, worst position:    " << p.esal_per_million[worst] << " at " << p.position_m[worst] << " m (95 %: "
     << p.esal_per_million_q025[worst] << " - " << p.esal_per_million_q975[worst] << ")\n"
     << "hot spots (95th percentile of a4 > " << p.hot_spot_threshold << "): " << hot << " of " << p.position_m.size()
     << " positions\n";
  if (p.lift_off_passes > 0) {
    os << "wheel lift-off (P < 0, counted as P = 0) in " << p.lift_off_passes << " of " << p.simulated_passes
       << " simulated passes\n";
  }
}
}  // namespace

int run_damage(int argc, const char* const argv[]) {
  std::string posterior_path, road = "AS1", out = "-", positions, seed_text = "1", png, class_label, mix_text;
  std::vector<double> extra_powers;
  bool new_road = false, quiet = false, fixed_traffic = false;
  damage::DamageOptions options;
  SiteFlags site_flags;
  SiteChoice where;
  po::options_description desc("damage options");
  desc.add_options()
      ("help,h", "show this help")
      ("posterior", po::value(&posterior_path)->value_name("PATH")->required(), kPosteriorHelp)
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("new-road", po::bool_switch(&new_road), "on a site other than the fitted one (another road or sensor array)")
      ("positions", po::value(&positions)->value_name("LIST"),
       "where: positions along the road (m) as a list 'a,b,c' or FIRST:STEP:LAST (default: the sensors)")
      ("power", po::value(&extra_powers)->value_name("N")->multitoken()->composing(),
       "further powers n of the weighted aggregate force, beyond 1 and 4 (e.g. --power 2 6)")
      ("threshold", po::value(&options.hot_spot_threshold)->value_name("X")->default_value(options.hot_spot_threshold, "1.1"),
       "hot spot: the 95th percentile of a4 over the posterior above this multiple of the static value")
      ("draws", po::value(&options.theta_draws)->value_name("N")->default_value(options.theta_draws), "posterior draws of theta")
      ("trucks-per-draw", po::value(&options.trucks_per_draw)->value_name("N")->default_value(options.trucks_per_draw),
       "simulated trucks per theta draw (a Latin hypercube over the observed truck, k, k_t, z)")
      ("fixed-traffic", po::bool_switch(&fixed_traffic),
       "the observed trucks' speeds and masses as the traffic itself (default: a Bayesian bootstrap of them)")
      ("class", po::value(&class_label)->value_name("LABEL"), "a posterior of vehicle classes: this class alone")
      ("mix", po::value(&mix_text)->value_name("SHARES"),
       "a posterior of vehicle classes: combine them in these traffic shares, e.g. A=0.7,B=0.3 (each >= 0, summing to "
       "1; a class left out has share 0; default: each class's observed share)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text), "random seed (a whole number)")
      ("out,o", po::value(&out)->value_name("FILE")->default_value(out), "damage CSV to write ('-' = standard output)")
      ("png", po::value(&png)->value_name("FILE"),
       "also plot a4 (with its 95 % limits), a1 and the hot spots along the road here (gnuplot; FILE ends in .png)")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  where.add_to(desc);
  site_flags.add_to(desc);
  refuse_options(argc, argv, {{"--state", "give a stream's state directory with --posterior DIR"}});
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet damage --posterior PATH [--road ROAD | --sites MANIFEST --site NAME] [--positions LIST] "
                     "[--power N ...] [--threshold X] [--out FILE] [--png FILE]",
                     "The summary (expected damage per million trucks, hot spots) goes to standard output, or to "
                     "standard error when the CSV does.")) {
    return 0;
  }
  const std::string& source = posterior_path;
  options.extra_powers = extra_powers;
  options.seed = parse_seed(seed_text);
  options.traffic_bootstrap = !fixed_traffic;
  options.validate();
  // The site first: a malformed --sites/--site is named before the posterior is read.
  const site::Site site = where.site(road, vm, site_flags);
  const ClassSelection selection = select_posterior_classes(source, class_label, mix_text, where.site_name);
  const fleet::ClassPosteriors& classes = selection.classes;
  const std::vector<double>& shares = selection.shares;
  const fleet::PosteriorCloud& cloud = classes.front().cloud;
  long total_trucks = 0;
  for (const auto& c : classes) total_trucks += c.cloud.trucks_seen;
  if (!new_road) require_fitted_site(cloud, source, site, "; pass --new-road to assess a different road on purpose");
  const auto profile = damage::predict_damage_mixture(classes, shares, site, parse_positions(positions), options);
  write_output(out, [&](std::ostream& os) { io::write_damage_csv(os, profile); });
  if (!png.empty()) plot_damage(png, out, profile, quiet);
  // The summary is a result: standard output, unless the CSV went there.
  print_summary(out == "-" ? std::cerr : std::cout, profile);
  if (!quiet) {
    std::cerr << "ssrfleet damage: " << profile.position_m.size() << " positions on road " << site.surface().name
              << " from " << total_trucks << " trucks (" << cloud.method << "), " << profile.simulated_passes
              << " simulated passes";
    if (!fleet::unlabelled(classes)) {
      std::cerr << "; classes";
      for (std::size_t c = 0; c < classes.size(); ++c) std::cerr << " " << classes[c].label << " (share " << shares[c] << ")";
    }
    std::cerr << "\n";
  }
  return 0;
}

}  // namespace ssrfleet::cli
