// What a stream prints and where its complaints about a log's columns point.
#include <string>

#include <catch2/catch.hpp>

#include "io/wim_log.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// A log of `trucks` simulated trucks at `path`, with `comments` comment lines above its header.
void write_log(const test::TempDir& dir, const std::string& path, int trucks, int comments) {
  const auto made = run_ssrfleet("simulate --trucks " + std::to_string(trucks) + " --seed 3 --out " + q(path), dir);
  REQUIRE(made.status == 0);
  std::string prefix;
  for (int i = 0; i < comments; ++i) prefix += "# a comment above the header\n";
  test::write_text(path, prefix + test::read_text(path));
}
}  // namespace

TEST_CASE("a stream whose last truck falls on --report-every prints that report once", "[cli][stream]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  write_log(dir, log, 6, 0);
  const auto r = run_ssrfleet("stream --state " + q(dir.file("st")) + " --input " + q(log) +
                                  " --particles 64 --report-every 3 --quiet",
                              dir);
  REQUIRE(r.status == 0);
  CHECK(count_of(r.out, "# SSR prediction after 3 trucks") == 1);
  CHECK(count_of(r.out, "# SSR prediction after 6 trucks") == 1);
  CHECK(count_of(r.out, "# SSR prediction after") == 2);
}

TEST_CASE("a log whose sensor count is not the site's is refused at its header's line", "[cli][stream][wim]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  write_log(dir, log, 3, 4);
  // The header's line: below simulate's own comment and the four added.
  const std::string text = test::read_text(log);
  int header = 1;
  std::size_t header_end = 0;
  while (text.compare(header_end, 8, "truck_id") != 0) {
    header_end = text.find('\n', header_end) + 1;
    ++header;
  }
  header_end = text.find('\n', header_end) + 1;
  REQUIRE(header > 4);
  const std::string at_header = "log.csv:" + std::to_string(header) + ":";
  // The default site has 16 sensors; this one 8, so the log's 16 columns do not fit.
  const std::string site = " --sensors 76,1.5,8";
  const auto fit = run_ssrfleet("fit " + q(log) + site + " --particles 64 --quiet --out " + q(dir.file("p.json")), dir);
  CHECK(fit.status == 65);
  CHECK_THAT(fit.err, Catch::Contains(at_header));
  const auto stream =
      run_ssrfleet("stream --state " + q(dir.file("st")) + " --input " + q(log) + site + " --particles 64 --quiet", dir);
  CHECK(stream.status == 65);
  CHECK_THAT(stream.err, Catch::Contains(at_header));
  // A log with no records after its header: the complaint points below the header.
  const std::string empty = dir.file("empty.csv");
  test::write_text(empty, text.substr(0, header_end));
  const auto none = test::data_error([&] { io::read_wim_log_file(empty, 420.0); });
  REQUIRE(none.has_value());
  CHECK(none->line() == static_cast<std::size_t>(header) + 1);
}
