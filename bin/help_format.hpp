// --help text that a person can copy from: wrapped on spaces only, never inside a token (a number,
// a key=value, an effect spec), at the terminal's width; laid out as GNU tools do, so that
// help2man turns it into a manual page (Usage:, Options:, "  -o, --out FILE   description").
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include <boost/program_options.hpp>

namespace ssrfleet::cli {

// The width help is wrapped to: $COLUMNS when it is a whole number (at least 20), else the
// terminal's width when standard output is one (at most 160, for readable lines), else 80.
int help_width();

// `text` wrapped to `width` columns on spaces only: the first line starts after `first_indent`
// columns already used by the caller, the others are indented by `indent` spaces. A word longer
// than the room left stands alone on its line, whole. '\n' in text starts a new line.
std::string wrap(const std::string& text, int width, int indent, int first_indent);

// A list of "tag  text" rows (options, commands, parameters): the texts aligned in one column,
// each wrapped under itself; a tag too long for the column puts its text on the next line, and
// on a narrow terminal every text goes on the line under its tag.
struct HelpRow {
  std::string tag, text;
};
std::string format_rows(const std::vector<HelpRow>& rows, int width, int max_tag_column);

// The rows of an options description as --help shows them ("-o, --out FILE", the description
// and "(default: X)"), each group of options under its own caption; the ungrouped ones under
// "Options:". Placeholders come from value_name (an option without one shows VALUE).
std::string format_options(const boost::program_options::options_description& desc, int width);

// A whole command page: "Usage: " before the first synopsis line of `usage` and "  or:  "
// before each further one, the paragraphs of `about`, then the options.
void print_command_help(std::ostream& os, const std::string& usage, const std::string& about,
                        const boost::program_options::options_description& desc, int width);

}  // namespace ssrfleet::cli
