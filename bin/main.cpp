// ssrfleet: parse the subcommand name, hand the rest to that subcommand, and turn exceptions
// into one clear message and a sysexits-style status: 64 usage, 65 data, 66 no input,
// 70 internal, 74 I/O.
#include <cstring>
#include <functional>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "util/errors.hpp"

namespace {

struct Command {
  std::function<int(int, const char* const*)> run;
  const char* summary;
};

const std::map<std::string, Command>& commands() {
  static const std::map<std::string, Command> table = {
      {"simulate", {ssrfleet::cli::run_simulate, "simulate a fleet over a road and write a WIM log"}},
      {"road", {ssrfleet::cli::run_road, "write a preset road surface or summarise a road file"}},
      {"fit", {ssrfleet::cli::run_fit, "fit the fleet posterior to a WIM log (SMC, or the batch MCMC)"}},
      {"stream", {ssrfleet::cli::run_stream, "update the posterior truck by truck from a live WIM stream (crash-safe)"}},
      {"predict", {ssrfleet::cli::run_predict, "predict the SSR pattern from a posterior, on this road or another"}},
      {"diagnose", {ssrfleet::cli::run_diagnose, "find, name and fit the effect the model misses (checks, extensions, Bayes factors)"}},
      {"damage", {ssrfleet::cli::run_damage, "damage along the road: fourth-power amplification, DLC, hot spots, ESAL per million trucks"}},
      {"weigh", {ssrfleet::cli::run_weigh, "SSR-corrected static wheel loads from a log of raw tyre forces"}},
      {"sites", {ssrfleet::cli::run_sites, "check a site manifest, list its sites, collect their posteriors into one table"}},
      {"reproduce", {ssrfleet::cli::run_reproduce, "the paper's theoretical test end to end: figure data, plots, summary.md"}},
  };
  return table;
}

void print_usage(std::ostream& os) {
  os << "ssrfleet " << SSRFLEET_VERSION
     << " - fleet suspension inference and statistical spatial repeatability from MS-WIM data\n\n"
        "usage: ssrfleet <command> [options]     (ssrfleet <command> --help for its options)\n\ncommands:\n";
  for (const auto& [name, cmd] : commands()) os << "  " << name << std::string(12 - name.size(), ' ') << cmd.summary << "\n";
}

}  // namespace

int main(int argc, char* argv[]) {
  if (argc < 2) {
    print_usage(std::cerr);
    return 64;
  }
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    print_usage(std::cout);
    return 0;
  }
  if (name == "--version") {
    std::cout << "ssrfleet " << SSRFLEET_VERSION << "\n";
    return 0;
  }
  const auto it = commands().find(name);
  if (it == commands().end()) {
    std::cerr << "ssrfleet: unknown command '" << name << "'\n\n";
    print_usage(std::cerr);
    return 64;
  }
  const std::string prefix = "ssrfleet " + name + ": ";
  try {
    return it->second.run(argc - 1, argv + 1);
  } catch (const ssrfleet::UsageError& e) {
    std::cerr << prefix << e.what() << "\n";
    return 64;
  } catch (const ssrfleet::DataError& e) {
    std::cerr << prefix << e.what() << "\n";
    return 65;
  } catch (const ssrfleet::MissingInputError& e) {
    std::cerr << prefix << e.what() << "\n";
    return 66;
  } catch (const ssrfleet::BusyError& e) {
    std::cerr << prefix << e.what() << "\n";
    return 75;
  } catch (const ssrfleet::IoError& e) {
    std::cerr << prefix << e.what() << "\n";
    return 74;
  } catch (const ssrfleet::NumericalError& e) {
    std::cerr << prefix << "numerical failure: " << e.what() << "\n";
    return 70;
  } catch (const std::invalid_argument& e) {
    std::cerr << prefix << e.what() << "\n";
    return 64;
  } catch (const std::out_of_range& e) {
    std::cerr << prefix << e.what() << "\n";
    return 64;
  } catch (const std::exception& e) {
    std::cerr << prefix << "internal error: " << e.what() << "\n";
    return 70;
  }
}
