// ssrfleet sites: a site manifest (io/site_manifest.hpp) checked and listed, its names for scripts,
// and the posteriors of its sites, fitted one by one (scripts/fit-sites.sh, a Slurm job array),
// collected into one table.
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fleet/posterior_summary.hpp"
#include "io/posterior_json.hpp"
#include "io/site_manifest.hpp"
#include "model/fleet_model.hpp"
#include "sites_check.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {

// One row per site: each site built (its road covers its sensors) and its log read whole (a site
// with no log, as a stream's manifest may have, lists no trucks). Returns the table; nothing is
// written unless every site passes.
std::string check_and_list(const io::SiteManifest& manifest, const SiteFlags& flags, bool quiet) {
  std::ostringstream out;
  out << "site,road,sensors,trucks,log\n";
  for (const auto& entry : manifest.sites) {
    SiteFlags own = flags;
    const site::Site site = site_of_manifest_entry(manifest, entry, own, quiet ? nullptr : &std::cerr);
    const std::string trucks =
        entry.log.empty() ? "" : std::to_string(read_manifest_site_log(manifest, entry, site, own).size());
    // RFC 4180 quotes: the sensor array holds commas, a path may.
    out << entry.name << ",\"" << entry.road << "\",\"" << entry.sensors << "\"," << trucks << ",\"" << entry.log
        << "\"\n";
  }
  return out.str();
}

// The summaries of every site's posterior DIR/NAME.json, one row per site, class and parameter.
// A posterior fitted on another site than its manifest entry (another road, sensor array or vehicle
// constants) is refused by name: a table that mixed sites up would be worse than none.
std::string collect(const io::SiteManifest& manifest, const SiteFlags& flags, const std::string& dir) {
  std::ostringstream out;
  out << "site,class,trucks,parameter,mean,sd,q025,q975\n";
  out << std::setprecision(10);
  for (const auto& entry : manifest.sites) {
    const std::string path = (std::filesystem::path(dir) / (entry.name + ".json")).string();
    if (!std::filesystem::exists(path)) {
      throw MissingInputError("site '" + entry.name + "': no posterior '" + path + "' (fit it with: ssrfleet fit --sites " +
                              manifest.path + " --site " + entry.name + " --out " + path + ")");
    }
    SiteFlags own = flags;
    const site::Site site = site_of_manifest_entry(manifest, entry, own, nullptr);
    for (const auto& [label, cloud] : io::read_posterior_classes(path)) {
      require_fitted_site(cloud, path, site,
                          " (site '" + entry.name + "' of manifest '" + manifest.path +
                              "'; refit it, with the same --m1, --cb, --ct and --envelopment as here)");
      const auto hyper = fleet::summarise_cloud(cloud);
      const auto psi = fleet::summarise_psi(cloud);
      const auto row = [&](const std::string& name, const fleet::ParameterSummary& s) {
        out << entry.name << "," << label << "," << cloud.trucks_seen << "," << name << "," << s.mean << "," << s.sd << ","
            << s.q025 << "," << s.q975 << "\n";
      };
      for (std::size_t h = 0; h < hyper.size(); ++h) row(std::string(fleet::kHyperNames[h]), hyper[h]);
      for (std::size_t k = 0; k < psi.size(); ++k) row(cloud.psi_names[k], psi[k]);
    }
  }
  return out.str();
}

}  // namespace

int run_sites(int argc, const char* const argv[]) {
  std::string manifest_path, collect_dir, out = "-", seed_text = "1";
  bool names = false, quiet = false, check = false;
  SiteFlags flags;
  SiteCheckFlags check_flags;
  po::options_description desc("sites options");
  desc.add_options()
      ("help,h", "show this help")
      ("manifest", po::value(&manifest_path)->value_name("MANIFEST")->required(),
       "the site manifest (JSON; positional: MANIFEST)")
      ("names", po::bool_switch(&names), "print the sites' names, one per line, and nothing else (for scripts)")
      ("collect", po::value(&collect_dir)->value_name("DIR"),
       "read each site's posterior DIR/NAME.json (fit --sites MANIFEST --site NAME) and write their summaries as one "
       "CSV table")
      ("check", po::bool_switch(&check),
       "flag a site whose fleet differs from the other sites': fits each site alone and the others without it, "
       "and compares their stiffness hyperparameters (a conflict p-value per site)")
      ("particles", po::value(&check_flags.particles)->value_name("N")->default_value(check_flags.particles),
       "--check: particles per fit")
      ("threads", po::value(&check_flags.threads)->value_name("N")->default_value(check_flags.threads),
       "--check: worker threads (0 = all cores)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text), "--check: random seed")
      ("alpha", po::value(&check_flags.alpha)->value_name("X")->default_value(check_flags.alpha, "0.01"),
       "--check: family-wise level; a site is flagged at p < alpha / sites")
      ("out,o", po::value(&out)->value_name("FILE")->default_value(out), "where the table goes ('-' = standard output)")
      ("quiet,q", po::bool_switch(&quiet),
       "print no warnings about the sites' roads and, with --check, no progress on standard error (errors and "
       "--check's verdict are still printed)");
  flags.add_to(desc, /*with_sensors=*/false);
  po::positional_options_description positional;
  positional.add("manifest", 1);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, &positional, vm,
                     "ssrfleet sites MANIFEST [--names | --collect DIR | --check] [--out FILE]",
                     "Without --names, --collect or --check: checks every site (its road covers its sensors, its log "
                     "reads whole with the site's sensor count) and lists them as CSV (site, road, sensors, trucks, "
                     "log). --check writes one row per site (its conflict p-value, the hyperparameters alone and from "
                     "the other sites) and names a flagged site on standard error.")) {
    return 0;
  }
  if (int(names) + int(!collect_dir.empty()) + int(check) > 1) throw UsageError("give one of --names, --collect and --check");
  check_flags.seed = parse_seed(seed_text);
  const io::SiteManifest manifest = io::read_site_manifest(manifest_path);
  if (check) {
    const std::string table = check_site_fleets(manifest, flags, check_flags, quiet ? nullptr : &std::cerr, std::cerr);
    write_output(out, [&](std::ostream& os) { os << table; });
    return 0;
  }
  if (names) {
    for (const auto& s : manifest.sites) std::cout << s.name << "\n";
    return 0;
  }
  const std::string table = collect_dir.empty() ? check_and_list(manifest, flags, quiet) : collect(manifest, flags, collect_dir);
  write_output(out, [&](std::ostream& os) { os << table; });
  return 0;
}

}  // namespace ssrfleet::cli
