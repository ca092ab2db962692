// ssrfleet: parse the subcommand name, hand the rest to that subcommand, and turn exceptions
// into one clear message and a sysexits-style status: 64 usage, 65 data, 66 no input,
// 70 internal, 74 I/O, 75 busy. Under mpirun (ssrfleet-mpi, docs/sites.md) rank 0 speaks for all.
#include <cstring>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "command_table.hpp"
#include "help_format.hpp"
#include "process_ranks.hpp"
#include "util/errors.hpp"

namespace {

using ssrfleet::cli::command_table;
using ssrfleet::cli::find_command;

void print_usage(std::ostream& os) {
  const int width = ssrfleet::cli::help_width();
  using ssrfleet::cli::HelpRow;
  using ssrfleet::cli::wrap;
  os << "Usage: ssrfleet COMMAND [OPTIONS]\n"
        "  or:  ssrfleet help [COMMAND]\n"
        "  or:  ssrfleet --version\n\n"
     << wrap(std::string("ssrfleet ") + SSRFLEET_VERSION +
                 ": fleet suspension inference and statistical spatial repeatability (SSR) from multiple-sensor "
                 "weigh-in-motion (MS-WIM) data.",
             width, 0, 0)
     << "\n\n";
  std::vector<HelpRow> rows;
  for (const auto& c : command_table()) rows.push_back({c.name, c.summary});
  rows.push_back({"help", "print a command's help: ssrfleet help COMMAND is ssrfleet COMMAND --help"});
  os << "Commands:\n" << ssrfleet::cli::format_rows(rows, width, 14) << "\n";
  os << wrap("Each command's options: ssrfleet help COMMAND (or ssrfleet COMMAND --help). Options that take a "
             "value accept --name VALUE and --name=VALUE.",
             width, 0, 0)
     << "\n\n";
  os << "Exit status:\n"
     << ssrfleet::cli::format_rows({{"0", "success"},
                                    {"64", "bad usage: an unknown command or option, a malformed value"},
                                    {"65", "bad data: an input file that cannot be read as what it should be"},
                                    {"66", "a missing input file or directory"},
                                    {"70", "an internal or numerical failure"},
                                    {"74", "an input/output error (a full disk, a read-only directory)"},
                                    {"75", "busy: the state directory is held by another stream"}},
                                   width, 8)
     << "\n";
  os << "Options:\n"
     << ssrfleet::cli::format_rows({{"-h, --help", "show this help"}, {"    --version", "print the version and exit"}},
                                   width, 18);
}

// The command's status (main() ends every rank on an error: see there).
int run_command(int argc, char* argv[]) {
  if (argc < 2) {
    print_usage(std::cerr);
    return 64;
  }
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || (name == "help" && argc == 2)) {
    print_usage(std::cout);
    return 0;
  }
  if (name == "--version") {
    std::cout << "ssrfleet " << SSRFLEET_VERSION << "\n";
    return 0;
  }
  // `help CMD` is `CMD --help`.
  const bool help = name == "help";
  if (help && (std::strcmp(argv[2], "--help") == 0 || std::strcmp(argv[2], "-h") == 0)) {
    print_usage(std::cout);
    return 0;
  }
  const std::string command_name = help ? argv[2] : name;
  const ssrfleet::cli::CommandInfo* command = find_command(command_name);
  if (command == nullptr || (help && argc > 3)) {
    if (help && command != nullptr) {
      std::cerr << "ssrfleet help: one command at a time: ssrfleet help " << command_name << "\n";
    } else {
      std::cerr << "ssrfleet: unknown command '" << command_name << "'\n\n";
      print_usage(std::cerr);
    }
    return 64;
  }
  const char* const help_argv[] = {command->name.c_str(), "--help", nullptr};
  const int command_argc = help ? 2 : argc - 1;
  const char* const* command_argv = help ? help_argv : argv + 1;
  // Rank 0 speaks for every rank; another rank's message names it.
  const std::string prefix =
      "ssrfleet " + command->name + (ssrfleet::cli::process_ranks().rank() == 0 ? "" : ssrfleet::cli::rank_label()) + ": ";
  try {
    // Several ranks share one fit's work; the other commands run on one process.
    if (ssrfleet::cli::process_ranks().size() > 1 && command->name != "fit") {
      throw ssrfleet::UsageError("runs on one process: of the commands, only fit spreads over MPI ranks "
                                 "(mpirun -np R ssrfleet-mpi fit ...); run ssrfleet " + command->name + " without mpirun");
    }
    return command->run(command_argc, command_argv);
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
