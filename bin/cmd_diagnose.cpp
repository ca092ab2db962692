// ssrfleet diagnose: where do the model and the measurements disagree, which physical effect is
// missing, and how much does adding it close the gap (lib/discrepancy/diagnose.hpp).
#include <iostream>
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "discrepancy/diagnose.hpp"
#include "discrepancy/diagnose_report.hpp"
#include "fleet/posterior_summary.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "model/model_extension.hpp"
#include "site/road_source.hpp"
#include "smc/engine.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

int run_diagnose(int argc, const char* const argv[]) {
  std::string log_path, road = "AS1", json_path, out_dir, seed_text = "1", candidates, posterior_path;
  discrepancy::DiagnoseOptions o;
  int threads = 0;
  bool quiet = false, no_plots = false, refit_from_prior = false;
  SiteFlags site_flags;
  // The families of posterior predictive checks the verdict divides alpha among.
  const int kCheckFamilies = static_cast<int>(fleet::CheckKind::kCount);
  std::string catalogue;
  for (const auto& name : fleet::extension_names()) {
    if (!catalogue.empty()) catalogue += ", ";
    catalogue += name;
  }
  po::options_description desc("diagnose options");
  desc.add_options()
      ("help,h", "show this help")
      ("log", po::value(&log_path)->value_name("FILE")->required(), "WIM log (CSV) to diagnose (positional: LOG)")
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("json", po::value(&json_path)->value_name("FILE"), "write the JSON report here ('-' = standard output)")
      ("out,o", po::value(&out_dir)->value_name("DIR"),
       "folder for the report, per-sensor CSVs, plots and posterior.json (the posterior it ends with)")
      ("posterior-out", po::value(&posterior_path)->value_name("FILE"),
       "write the posterior diagnose ends with (the chosen effect's model, or the base model) here, ready for predict "
       "--posterior")
      ("particles", po::value(&o.particles)->value_name("N")->default_value(o.particles), "SMC particles per fit (>= 2)")
      ("threads", po::value(&threads)->value_name("N")->default_value(threads),
       "worker threads; 0 = all cores (results do not depend on it)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text), "random seed (a whole number)")
      ("alpha", po::value(&o.alpha)->value_name("X")->default_value(o.alpha),
       ("a check is flagged when its predictive p-value is below alpha; the verdict that a misfit remains needs a "
        "check below alpha / " + std::to_string(kCheckFamilies) +
        ", one share for each of the " + std::to_string(kCheckFamilies) + " check families (Bonferroni)").c_str())
      ("min-log-bf", po::value(&o.min_log_bayes_factor)->value_name("X")->default_value(o.min_log_bayes_factor),
       "log Bayes factor an effect needs against the model before it (the base model, or the effects named so far)")
      ("holdout", po::value(&o.holdout_fraction)->value_name("X")->default_value(o.holdout_fraction),
       "share of the trucks (the last ones) that score held-out skill")
      ("candidates", po::value(&candidates)->value_name("LIST"),
       ("effects to consider, comma-separated (default: all of them: " + catalogue + "; ssrfleet effects describes them)").c_str())
      ("max-effects", po::value(&o.max_effects)->value_name("N")->default_value(o.max_effects),
       "effects added at most: after each, diagnose checks again and weighs every remaining effect on top of it by "
       "evidence and held-out skill, whether or not a check still fails")
      ("shortlist-only", po::bool_switch(&o.shortlist_only),
       "refit only candidates that a failed check points at (faster; misses effects the checks cannot see)")
      ("refit-from-prior", po::bool_switch(&refit_from_prior),
       "refit candidates drawing each new truck from the fleet prior, not from its table in the base fit "
       "(slower; for comparison)")
      ("draws", po::value(&o.draws)->value_name("N")->default_value(o.draws), "posterior draws behind the checks")
      ("no-plots", po::bool_switch(&no_plots), "write the gnuplot scripts but do not run gnuplot")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  site_flags.add_to(desc);
  po::positional_options_description positional;
  positional.add("log", 1);
  refuse_options(argc, argv, {{"--posterior", "the posterior diagnose ends with is an output: --posterior-out FILE"}});
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, &positional, vm,
                     "ssrfleet diagnose LOG [--road ROAD] [--json FILE] [--out DIR] [--posterior-out FILE] "
                     "[--particles N] [--candidates LIST]",
                     "The verdict and each candidate effect's evidence go to standard output (unless --json -).")) {
    return 0;
  }
  check_particles(o.particles);
  o.seed = parse_seed(seed_text);
  if (threads < 0) throw UsageError("--threads must be >= 0");
  o.threads = threads > 0 ? threads : smc::TemperedSampler::Options::default_threads();
  if (!candidates.empty()) {
    std::stringstream ss(candidates);
    std::string name;
    while (std::getline(ss, name, ',')) {
      if (!name.empty()) o.candidates.push_back(name);
    }
  }
  o.refit_from_tables = !refit_from_prior;
  o.validate();
  const site::Site site(site::load_road(road, &std::cerr), site_flags.to_options());
  for (const auto& name : o.candidates) fleet::make_extension(name, site);  // unknown names fail before any work
  const auto records = read_site_log(log_path, site, site_flags);
  // Printed even with --quiet: it is about the answer. Classes are fitted apart by `fit`.
  if (!records.empty() && !records.front().vehicle_class.empty()) {
    std::cerr << "ssrfleet diagnose: warning: the log's class column is ignored: diagnose fits all its trucks as one "
                 "fleet (fit the classes apart with `ssrfleet fit`, or diagnose each class's records alone)\n";
  }
  if (!quiet) o.progress = &std::cerr;
  const auto result = discrepancy::diagnose(site, records, o);
  if (!json_path.empty()) {
    write_output(json_path, [&](std::ostream& os) { os << discrepancy::diagnosis_to_json(result).dump(1) << "\n"; });
  }
  if (!posterior_path.empty()) {
    write_output(posterior_path, [&](std::ostream& os) {
      os << io::posterior_file_text(io::posterior_to_json(result.posterior, fleet::summarise_cloud(result.posterior),
                                                          fleet::summarise_psi(result.posterior)));
    });
  }
  if (!out_dir.empty()) {
    bool plotted = false;
    const auto files = discrepancy::write_diagnosis_files(out_dir, result, !no_plots, &plotted);
    if (!quiet) {
      std::cerr << "diagnose: wrote " << files.size() << " files to " << out_dir
                << (plotted || no_plots ? "" : " (gnuplot not run: install gnuplot, then `gnuplot residual_pattern.gp` there)")
                << "\n";
    }
  }
  if (json_path != "-") discrepancy::print_diagnosis(std::cout, result);
  return 0;
}

}  // namespace ssrfleet::cli
