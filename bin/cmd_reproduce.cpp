// ssrfleet reproduce: the paper's theoretical test end to end (lib/reproduce): the data behind
// Figs. 4 and 6-9, the posterior's evolution, plots, and summary.md beside the paper's numbers.
#include <iostream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "reproduce/paper_reproduction.hpp"

namespace ssrfleet::cli {

int run_reproduce(int argc, const char* const argv[]) {
  reproduce::Options o;
  o.out_dir = "reproduce";
  std::string seed_text = "1";
  bool quiet = false, no_plots = false;
  po::options_description desc("reproduce options");
  desc.add_options()
      ("help,h", "show this help")
      ("out,o", po::value(&o.out_dir)->value_name("DIR")->default_value(o.out_dir), "folder for the CSVs, plots and summary.md")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text),
       "random seed (fleet, noise, SMC, prediction; a whole number)")
      ("trucks", po::value(&o.trucks)->value_name("N")->default_value(o.trucks), "trucks in the fleet (the paper: 100)")
      ("particles", po::value(&o.particles)->value_name("N")->default_value(o.particles), "SMC particles (>= 2)")
      ("threads", po::value(&o.threads)->value_name("N")->default_value(o.threads), "worker threads; 0 = all cores")
      ("noise", po::value(&o.noise_sd)->value_name("SD")->default_value(o.noise_sd), "measurement noise sd sigma_IF")
      ("model", po::value(&o.model)->value_name("SPEC")->default_value(o.model),
       "the model the fits use: base (the paper's) or effects joined by '+' (a parameter given is fixed, one left out "
       "fitted; ssrfleet effects lists them)")
      ("effect", po::value(&o.effect)->value_name("SPEC"),
       "hide effects in the simulated data, every parameter given (e.g. speed_bias:factor=1.05); the paper's data has none")
      ("draws", po::value(&o.theta_draws)->value_name("N")->default_value(o.theta_draws), "prediction: posterior draws of theta")
      ("trucks-per-draw", po::value(&o.trucks_per_draw)->value_name("N")->default_value(o.trucks_per_draw),
       "prediction: simulated trucks per theta draw")
      ("no-plots", po::bool_switch(&no_plots), "write the gnuplot scripts but do not run gnuplot")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet reproduce [--out DIR] [--seed SEED] [--trucks N] [--particles N] [--noise SD]")) {
    return 0;
  }
  check_particles(o.particles);
  o.seed = parse_seed(seed_text);
  o.plots = !no_plots;
  o.progress = quiet ? nullptr : &std::cerr;
  reproduce::run(o);
  return 0;
}

}  // namespace ssrfleet::cli
