#include "help_format.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <ostream>
#include <sstream>

namespace ssrfleet::cli {

namespace po = boost::program_options;

namespace {

// Columns a UTF-8 string takes (its code points: the help's µ, σ and × are one column each).
int columns(const std::string& s) {
  return static_cast<int>(std::count_if(
      s.begin(), s.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, sep)) parts.push_back(part);
  return parts;
}

// An option as its row's tag: "-o, --out FILE" or "    --seed SEED"; its default goes to the text.
HelpRow option_row(const po::option_description& option) {
  const std::string short_name = option.canonical_display_name(po::command_line_style::allow_dash_for_short);
  const bool has_short = short_name.size() == 2 && short_name[0] == '-';
  HelpRow row;
  row.tag = (has_short ? short_name + ", " : std::string(4, ' ')) +
            option.canonical_display_name(po::command_line_style::allow_long);
  // program_options writes a value's parameter as "NAME" or "NAME (=DEFAULT)"; a switch has none.
  std::string parameter = option.format_parameter();
  std::string default_text;
  if (const auto at = parameter.find(" (="); at != std::string::npos && parameter.back() == ')') {
    default_text = parameter.substr(at + 3, parameter.size() - at - 4);
    parameter.erase(at);
  }
  if (!parameter.empty()) row.tag += " " + parameter;
  row.text = option.description();
  // Appended piece by piece: GCC 12 sees a false -Wrestrict overlap in "literal" + std::string.
  if (!default_text.empty()) {
    if (!row.text.empty()) row.text += ' ';
    row.text.append("(default: ").append(default_text).append(")");
  }
  return row;
}

// The options of `desc` under their captions, in the order program_options prints them (its own
// options, then each group added to it); program_options keeps the groups to itself, so they are
// read back from its own listing, where a caption is a line "CAPTION:" and an option's first line
// starts "  " followed by its name as format_name() writes it.
std::vector<std::pair<std::string, std::vector<const po::option_description*>>> sections_of(
    const po::options_description& desc) {
  std::ostringstream listing;
  listing << desc;
  std::vector<std::pair<std::string, std::vector<const po::option_description*>>> sections;
  std::vector<const po::option_description*> placed;
  for (const std::string& line : split(listing.str(), '\n')) {
    if (line.empty()) continue;
    if (line[0] != ' ' && line.back() == ':') {
      sections.push_back({sections.empty() ? "Options" : line.substr(0, line.size() - 1), {}});
      continue;
    }
    if (line.size() < 3 || line.compare(0, 2, "  ") != 0 || line[2] == ' ')
      continue;  // a description's next line
    for (const auto& option : desc.options()) {
      const std::string name = "  " + option->format_name();
      if (line.compare(0, name.size(), name) == 0 &&
          (line.size() == name.size() || line[name.size()] == ' ') &&
          std::find(placed.begin(), placed.end(), option.get()) == placed.end()) {
        if (sections.empty()) sections.push_back({"Options", {}});
        sections.back().second.push_back(option.get());
        placed.push_back(option.get());
        break;
      }
    }
  }
  for (const auto& option : desc.options()) {  // none should be left, but none may be lost either
    if (std::find(placed.begin(), placed.end(), option.get()) != placed.end()) continue;
    if (sections.empty()) sections.push_back({"Options", {}});
    sections.front().second.push_back(option.get());
  }
  return sections;
}

}  // namespace

int help_width() {
  if (const char* env = std::getenv("COLUMNS")) {
    const std::string text = env;
    int value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    // One column short of the full width: a line that fills a terminal's last column makes some
    // terminals add an empty line after it.
    if (ec == std::errc() && end == text.data() + text.size() && value > 0) return std::max(20, value) - 1;
  }
  winsize size{};
  if (::isatty(STDOUT_FILENO) && ::ioctl(STDOUT_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) {
    return std::clamp(static_cast<int>(size.ws_col), 20, 160) - 1;
  }
  return 79;
}

std::string wrap(const std::string& text, int width, int indent, int first_indent) {
  std::string out;
  const std::string margin(static_cast<std::size_t>(indent), ' ');
  int column = first_indent;
  bool line_empty = true;
  const auto new_line = [&] {
    out += '\n';
    out += margin;
    column = indent;
    line_empty = true;
  };
  const std::vector<std::string> lines = split(text, '\n');
  for (std::size_t l = 0; l < lines.size(); ++l) {
    if (l > 0) new_line();
    for (const std::string& word : split(lines[l], ' ')) {
      if (word.empty()) continue;
      const int length = columns(word);
      if (!line_empty && column + 1 + length > width) new_line();
      if (!line_empty) {
        out += ' ';
        ++column;
      }
      out += word;
      column += length;
      line_empty = false;
    }
  }
  return out;
}

std::string format_rows(const std::vector<HelpRow>& rows, int width, int max_tag_column) {
  int longest = 0;
  for (const auto& row : rows) longest = std::max(longest, columns(row.tag));
  // The texts start two columns after the longest tag that fits, and never in the left third's
  // first 16 columns, so that a narrow terminal still gives each text some room.
  int column = std::max(std::min(2 + longest + 2, max_tag_column), std::min(16, width / 3));
  // A narrow terminal leaves the texts too little room beside the tags: each goes under its tag.
  const bool stacked = width - column < 28;
  if (stacked) column = 10;
  std::string out;
  for (const auto& row : rows) {
    const std::string head = "  " + row.tag;
    out += head;
    if (row.text.empty()) {
      out += "\n";
      continue;
    }
    if (stacked || columns(head) + 2 > column) {
      out += '\n';
      out.append(static_cast<std::size_t>(column), ' ');
    } else {
      out += std::string(static_cast<std::size_t>(column - columns(head)), ' ');
    }
    out += wrap(row.text, width, column, column) + "\n";
  }
  return out;
}

std::string format_options(const po::options_description& desc, int width) {
  std::string out;
  for (const auto& [caption, options] : sections_of(desc)) {
    if (options.empty()) continue;
    std::vector<HelpRow> rows;
    for (const auto* option : options) rows.push_back(option_row(*option));
    out +=
        (out.empty() ? "" : "\n") + caption + ":\n" + format_rows(rows, width, std::max(24, width * 2 / 5));
  }
  return out;
}

void print_command_help(std::ostream& os, const std::string& usage, const std::string& about,
                        const po::options_description& desc, int width) {
  const std::vector<std::string> synopses = split(usage, '\n');
  for (std::size_t i = 0; i < synopses.size(); ++i) {
    os << (i == 0 ? "Usage: " : "  or:  ") << wrap(synopses[i], width, 7, 7) << "\n";
  }
  std::string text = about;
  // Paragraphs: separated by an empty line.
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find("\n\n", start);
    if (end == std::string::npos) end = text.size();
    os << "\n" << wrap(text.substr(start, end - start), width, 0, 0) << "\n";
    start = end + 2;
  }
  os << "\n" << format_options(desc, width);
}

}  // namespace ssrfleet::cli
