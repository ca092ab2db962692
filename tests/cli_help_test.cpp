// The help a person copies from: every command's --help (and `ssrfleet help CMD`, the same text)
// at several terminal widths never splits a token (a number, a key=value, an effect spec) across
// lines, names every placeholder, and `ssrfleet effects` lists the catalogue. The manual pages
// help2man makes from the help have their sections, and `cmake --install` puts the binaries,
// pages and documents where they belong.
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {

std::string q(const std::string& path) { return "'" + path + "'"; }

// Sets (or, with nullopt, removes) $COLUMNS for the commands a test runs, and restores it after.
class ColumnsGuard {
 public:
  explicit ColumnsGuard(const std::optional<int>& columns) {
    if (const char* old = std::getenv("COLUMNS")) old_ = old;
    if (columns) {
      ::setenv("COLUMNS", std::to_string(*columns).c_str(), 1);
    } else {
      ::unsetenv("COLUMNS");
    }
  }
  ~ColumnsGuard() {
    if (old_) {
      ::setenv("COLUMNS", old_->c_str(), 1);
    } else {
      ::unsetenv("COLUMNS");
    }
  }
  ColumnsGuard(const ColumnsGuard&) = delete;
  ColumnsGuard& operator=(const ColumnsGuard&) = delete;

 private:
  std::optional<std::string> old_;
};

std::string help_text(const std::string& args, const std::optional<int>& columns, const test::TempDir& dir) {
  const ColumnsGuard guard(columns);
  const auto r = run_ssrfleet(args, dir);
  INFO("ssrfleet " << args << "\n" << r.err);
  REQUIRE(r.status == 0);
  return r.out;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

std::vector<std::string> words_of(const std::string& text) {
  std::vector<std::string> words;
  std::istringstream in(text);
  std::string word;
  while (in >> word) words.push_back(word);
  return words;
}

int columns_of(const std::string& line) {
  int n = 0;
  for (const char c : line) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
  return n;
}

bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; }

bool is_operator(const std::string& word) {  // "=", ">=", "-/+": a word of its own in prose
  return word.find_first_not_of("=<>!-/+") == std::string::npos;
}

// Where the text splits a token across two lines, by the marks a split leaves and ordinary
// wrapping on spaces does not: a line that starts with a character no word starts with
// (":sensor=11"), a line that ends inside a key=value or a bracket ("c_t=", "("), a number cut in
// two ("c_t=40" then "0"), or a comma-separated list cut in two ("...,sensor_gain,spe" then
// "ed_bias,..."). A split that leaves none of these marks ("unsprung_m" then "ass)") is found by
// comparing the words with those of the unwrapped text. With `width`, also a line longer than the
// width that holds more than one word: a wrap that ignores the terminal. Each problem names its line.
std::vector<std::string> split_tokens(const std::string& text, std::optional<int> width = std::nullopt) {
  std::vector<std::string> problems;
  const auto lines = lines_of(text);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    const auto where = [&](const std::string& what) {
      problems.push_back("line " + std::to_string(i + 1) + ": " + what + ": '" + line + "'" +
                         (i + 1 < lines.size() ? " / '" + lines[i + 1] + "'" : ""));
    };
    if (width && columns_of(line) > *width && words_of(line).size() > 1) where("longer than the width");
    if (i + 1 == lines.size() || line.empty() || line.back() == ' ') continue;
    const std::string& next = lines[i + 1];
    const auto first = next.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    const std::string tail = words_of(line).back(), head = words_of(next).front();
    const char a = line.back(), b = next[first];
    if (std::string(":=,;)]}").find(b) != std::string::npos && !is_operator(head)) {
      where("the next line starts inside a token");
    }
    if (std::string("([{").find(a) != std::string::npos ||
        (a == '=' && tail.size() > 1 && is_word_char(tail[tail.size() - 2]))) {
      where("the line ends inside a token");
    }
    if (std::isdigit(static_cast<unsigned char>(a)) && std::isdigit(static_cast<unsigned char>(b)) &&
        tail.find_first_of("=,.") != std::string::npos) {
      where("a number is cut in two");
    }
    if (is_word_char(a) && is_word_char(b) && tail.find(',') != std::string::npos &&
        head.find(',') != std::string::npos) {
      where("a list is cut in two");
    }
  }
  return problems;
}

std::map<std::string, int> word_counts(const std::string& text) {
  std::map<std::string, int> counts;
  for (const auto& w : words_of(text)) ++counts[w];
  return counts;
}

// The commands the general help lists.
std::vector<std::string> listed_commands(const std::string& general_help) {
  std::vector<std::string> names;
  bool in_list = false;
  for (const auto& line : lines_of(general_help)) {
    if (line == "Commands:") {
      in_list = true;
    } else if (line.empty()) {
      in_list = false;
    } else if (in_list && line.size() > 2 && line[2] != ' ') {
      const std::string name = words_of(line).front();
      if (name != "help") names.push_back(name);
    }
  }
  return names;
}

const std::vector<std::string> kCommands = {"damage", "diagnose", "draws",  "effects", "fit",    "predict",
                                            "reproduce", "road", "serve", "simulate", "sites", "stream", "weigh"};

// The build tree: the ssrfleet binary sits at its top.
std::filesystem::path build_dir() { return std::filesystem::path(SSRFLEET_BINARY).parent_path(); }

}  // namespace

TEST_CASE("the check for split tokens finds program_options' splits and passes a wrap on spaces", "[cli][help]") {
  // program_options at 80 columns, as simulate and diagnose printed their help with it.
  const std::string old_simulate =
      "  --model arg                simulate with effects the base model leaves out: \n"
      "                             effects joined by '+', each NAME:param=value,... \n"
      "                             with every parameter given (e.g. \n"
      "                             sensor_gain:sensor=5,gain=1.05+tyre_damping:c_t=40\n"
      "                             0; see `ssrfleet diagnose --help` for the \n"
      "                             catalogue)\n";
  const std::string old_diagnose =
      "  --candidates arg           extensions to consider, comma-separated (default: \n"
      "                             all of profile_defect,second_class,sensor_gain,spe\n"
      "                             ed_bias,suspension_damping,tyre_damping,unsprung_m\n"
      "                             ass)\n";
  const std::string old_fit =
      "                                      (a parameter given is fixed, one left out\n"
      "                                      is fitted), e.g. tyre_damping+sensor_gain\n"
      "                                      :sensor=11; effects need the latent core \n";
  CHECK(split_tokens(old_simulate).size() == 1);  // c_t=40 / 0
  // spe / ed_bias; unsprung_m / ass leaves no mark that a wrap on spaces cannot leave (a line may
  // end in an identifier and the next start with a word): the comparison with the unwrapped help
  // in the next case finds such a split.
  CHECK(split_tokens(old_diagnose).size() == 1);
  CHECK(split_tokens(old_fit).size() == 1);  // sensor_gain / :sensor=11
  // The same words wrapped on spaces: nothing to report, at any width.
  const std::string clean =
      "  --model SPEC   simulate with effects joined by '+', e.g.\n"
      "                 sensor_gain:sensor=5,gain=1.05+tyre_damping:c_t=400\n"
      "                 (default: all of profile_defect,second_class,sensor_gain,speed_bias)\n"
      "                 0 = off; '-' = standard output; the sensors 1 to\n"
      "                 16 (positional: LOG)\n";
  CHECK(split_tokens(clean).empty());
  CHECK(split_tokens(clean, 40).size() == 3);  // three lines of several words past 40 columns
}

TEST_CASE("every command's help keeps each token whole at any width and names its placeholders, and help CMD is it",
          "[cli][help]") {
  test::TempDir dir;
  const std::string general = help_text("--help", std::nullopt, dir);
  CHECK(listed_commands(general) == kCommands);  // kCommands is sorted, as the help lists them
  CHECK(general.find("--version") != std::string::npos);
  CHECK(help_text("help", std::nullopt, dir) == general);
  const auto version = run_ssrfleet("--version", dir);
  CHECK(version.status == 0);
  CHECK(version.out.rfind("ssrfleet ", 0) == 0);

  std::vector<std::string> pages = {"--help"};
  for (const auto& c : kCommands) pages.push_back(c + " --help");
  pages.push_back("effects");
  const std::regex arg_placeholder(R"((^|\s)arg(\s|$))");
  for (const std::string& page : pages) {
    // The widest rendering wraps nothing: the words every narrower one must keep whole.
    const std::string wide = help_text(page, 1000, dir);
    const auto wide_words = word_counts(wide);
    for (const std::optional<int> columns :
         {std::optional<int>(40), std::optional<int>(80), std::optional<int>(200), std::optional<int>()}) {
      const std::string text = help_text(page, columns, dir);
      INFO("ssrfleet " << page << " at COLUMNS=" << (columns ? std::to_string(*columns) : "unset") << ":\n"
                       << text);
      // Without COLUMNS (and not on a terminal) the help is 80 columns wide.
      std::string problems;
      for (const auto& p : split_tokens(text, columns.value_or(80))) problems += p + "\n";
      CHECK(problems == "");
      CHECK(word_counts(text) == wide_words);
      CHECK_FALSE(std::regex_search(text, arg_placeholder));
      const std::string name = words_of(page).front();
      if (name != "--help" && page != "effects") CHECK(help_text("help " + name, columns, dir) == text);
    }
  }
  const auto unknown = run_ssrfleet("help frobnicate", dir);
  CHECK(unknown.status == 64);
  CHECK(unknown.err.find("unknown command 'frobnicate'") != std::string::npos);
}

TEST_CASE(
    "effects prints the catalogue: every effect with its parameters, units and ranges, and the spec syntax",
    "[cli][help]") {
  test::TempDir dir;
  const std::string text = help_text("effects", std::nullopt, dir);
  for (const char* effect : {"sensor_gain", "tyre_damping", "unsprung_mass", "suspension_damping",
                             "profile_defect", "speed_bias", "second_class"}) {
    INFO(effect);
    CHECK(text.find(std::string("\n") + effect + ": ") != std::string::npos);
  }
  // Units, ranges and null values as the registry holds them; the site's own ranges.
  CHECK(text.find("c_t         N s/m; in [0, 10000]; null value 0") != std::string::npos);
  CHECK(text.find("sensor      no unit; in [0.5, 16.5]; null value 1") != std::string::npos);
  CHECK(text.find("tyre_damping+sensor_gain:sensor=11") != std::string::npos);
  const std::string twelve = help_text("effects --sensors 76,1.5,12", std::nullopt, dir);
  CHECK(twelve.find("sensor      no unit; in [0.5, 12.5]") != std::string::npos);
  // The vehicle constants' null values are the site's.
  CHECK(help_text("effects --ct 300", std::nullopt, dir)
            .find("c_t         N s/m; in [0, 10000]; null value 300") != std::string::npos);
}

TEST_CASE("help2man makes a command's manual page from its help, with NAME, SYNOPSIS and OPTIONS",
          "[cli][help][man]") {
  test::TempDir dir;
  const std::string page = dir.file("ssrfleet-fit.1");
  const std::string script = std::string(SSRFLEET_SOURCE_DIR) + "/bin/man_page.sh";
  const int status =
      std::system(("sh " + q(script) + " " + q(SSRFLEET_BINARY) + " " + q(page) + " fit").c_str());
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  const std::string text = test::read_text(page);
  INFO(text);
  for (const char* section :
       {".SH NAME", ".SH SYNOPSIS", ".SH DESCRIPTION", ".SH OPTIONS", ".SH \"SEE ALSO\""}) {
    CHECK(text.find(section) != std::string::npos);
  }
  CHECK(text.find("ssrfleet-fit \\- fit the fleet posterior") != std::string::npos);
  CHECK(text.find(".B ssrfleet") != std::string::npos);                  // the synopsis, from the usage line
  CHECK(text.find("\\fB\\-\\-particles\\fR N\n") != std::string::npos);  // an option and its placeholder
  CHECK(text.find(".SS \"SMC options:\"") != std::string::npos);         // a group of options
}

TEST_CASE("cmake --install puts the command, its manual pages and the documents in the prefix",
          "[cli][install]") {
  test::TempDir dir;
  const std::filesystem::path prefix = dir.path() / "prefix";
  const std::string build = build_dir().string();
  const auto run = [&](const std::string& command) {
    const int status = std::system((command + " > " + q(dir.file("log.txt")) + " 2>&1").c_str());
    INFO(command << "\n" << test::read_text(dir.file("log.txt")));
    REQUIRE(WIFEXITED(status));
    REQUIRE(WEXITSTATUS(status) == 0);
  };
  run("cmake --build " + q(build) + " --target man");
  run("cmake --install " + q(build) + " --prefix " + q(prefix.string()));

  const std::filesystem::path binary = prefix / "bin" / "ssrfleet";
  REQUIRE(std::filesystem::exists(binary));
  CHECK((std::filesystem::status(binary).permissions() & std::filesystem::perms::owner_exec) !=
        std::filesystem::perms::none);
  run(q(binary.string()) + " --version");
  if (std::filesystem::exists(build_dir() / "ssrfleet-mpi"))
    CHECK(std::filesystem::exists(prefix / "bin" / "ssrfleet-mpi"));
  // A page for ssrfleet and for every command its help lists.
  const std::filesystem::path man = prefix / "share" / "man" / "man1";
  CHECK(std::filesystem::exists(man / "ssrfleet.1"));
  for (const auto& c : listed_commands(help_text("--help", std::nullopt, dir))) {
    INFO(c);
    CHECK(std::filesystem::exists(man / ("ssrfleet-" + c + ".1")));
  }
  // The README, the guide and the examples, each file of the source's folders.
  const std::filesystem::path doc = prefix / "share" / "doc" / "ssrfleet";
  CHECK(std::filesystem::exists(doc / "README.md"));
  for (const char* folder : {"docs", "examples"}) {
    const std::filesystem::path source = std::filesystem::path(SSRFLEET_SOURCE_DIR) / folder;
    if (!std::filesystem::is_directory(source)) continue;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(source)) {
      if (!entry.is_regular_file()) continue;
      const auto relative = std::filesystem::relative(entry.path(), source);
      INFO(folder << "/" << relative.string());
      CHECK(std::filesystem::exists(doc / folder / relative));
    }
  }
  CHECK(std::filesystem::is_directory(doc / "docs"));
}
