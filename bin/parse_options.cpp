// parse_or_help and refuse_options (cli_common.hpp): apart from cli_common.cpp, which the fuzz
// harnesses link alone, because the help needs the command table and so every command.
#include <cctype>
#include <iostream>

#include "cli_common.hpp"
#include "command_table.hpp"
#include "help_format.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

bool parse_or_help(int argc, const char* const argv[], const po::options_description& desc,
                   const po::positional_options_description* positional, po::variables_map& vm,
                   const std::string& usage, const std::string& about) {
  try {
    po::command_line_parser parser(argc, argv);
    parser.options(desc);
    if (positional) parser.positional(*positional);
    po::store(parser.run(), vm);
    if (vm.count("help")) {
      std::string text;
      if (const CommandInfo* command = argc > 0 ? find_command(argv[0]) : nullptr) {
        text = command->summary + ".";
        text[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
      }
      if (!about.empty()) text += (text.empty() ? "" : "\n\n") + about;
      print_command_help(std::cout, usage, text, desc, help_width());
      return false;
    }
    po::notify(vm);
  } catch (const po::error& e) {
    throw UsageError(std::string(e.what()) + " (see --help)");
  }
  return true;
}

void refuse_options(int argc, const char* const argv[], const std::vector<RefusedOption>& refused) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") return;  // what follows is not an option
    for (const auto& r : refused) {
      if (arg == r.name || arg.rfind(r.name + "=", 0) == 0) {
        throw UsageError(r.name + " is not an option of " + argv[0] + ": " + r.instead);
      }
    }
  }
}

}  // namespace ssrfleet::cli
