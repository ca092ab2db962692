// ssrfleet: parse the subcommand name, hand the rest to that subcommand, and turn exceptions
// into one clear message and a sysexits-style status: 64 usage, 65 data, 66 no input,
// 70 internal, 74 I/O. Under mpirun (ssrfleet-mpi, README "Scale-out on MPI") rank 0 speaks for all.
#include <cstring>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "process_ranks.hpp"
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

// The command's status (main() ends every rank on an error: see there).
int run_command(int argc, char* argv[]) {
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
  // Rank 0 speaks for every rank; another rank's message names it.
  const std::string prefix =
      "ssrfleet " + name + (ssrfleet::cli::process_ranks().rank() == 0 ? "" : ssrfleet::cli::rank_label()) + ": ";
  try {
    // Several ranks share one fit's work; the other commands run on one process.
    if (ssrfleet::cli::process_ranks().size() > 1 && name != "fit") {
      throw ssrfleet::UsageError("runs on one process: of the commands, only fit spreads over MPI ranks "
                                 "(mpirun -np R ssrfleet-mpi fit ...); run ssrfleet " + name + " without mpirun");
    }
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

}  // namespace

int main(int argc, char* argv[]) {
  try {
    ssrfleet::cli::start_process_ranks(&argc, &argv);
  } catch (const std::exception& e) {
    std::cerr << "ssrfleet: cannot start: " << e.what() << "\n";
    return 70;
  }
  // Rank 0 speaks for every rank: the others' standard output and error go nowhere, except for an
  // error of their own (below, which must be seen: it ends the run).
  std::ostringstream quiet_out, quiet_err;
  std::streambuf* const err = std::cerr.rdbuf();
  std::streambuf* const out = std::cout.rdbuf();
  const bool speaks = ssrfleet::cli::process_ranks().rank() == 0;
  if (!speaks) {
    std::cout.rdbuf(quiet_out.rdbuf());
    std::cerr.rdbuf(quiet_err.rdbuf());
  }
  const int status = run_command(argc, argv);
  std::cout.rdbuf(out);
  std::cerr.rdbuf(err);
  // On several ranks any error ends the job: even one that every rank would meet alike (a bad
  // option) may have met only some of them (a file one rank could not read), and a rank that
  // finishes while the others wait in a collective would leave mpirun hanging. A rank other than 0
  // shows its message (it names the rank) before the abort.
  if (status != 0 && ssrfleet::cli::process_ranks().size() > 1) {
    if (!speaks) std::cerr << quiet_err.str();
    std::cout.flush();  // MPI_Abort does not flush
    std::cerr.flush();
    ssrfleet::cli::abort_process_ranks(status);
  }
  ssrfleet::cli::stop_process_ranks();
  return status;
}
