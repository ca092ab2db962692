// The commands of ssrfleet: each one's name, its entry point and the one-line summary that the
// general help lists and that opens the command's own help (and its manual page's NAME).
#pragma once

#include <string>
#include <vector>

namespace ssrfleet::cli {

struct CommandInfo {
  std::string name;
  int (*run)(int argc, const char* const argv[]);
  std::string summary;
};

// Sorted by name.
const std::vector<CommandInfo>& command_table();
// Null for a name that is not a command.
const CommandInfo* find_command(const std::string& name);

}  // namespace ssrfleet::cli
