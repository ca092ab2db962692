// fit --checkpoint DIR (io/fit_checkpoint.hpp): a fit goes on from its
// checkpoint with the bits of a run that never stopped, and a checkpoint that does not belong to
// the log, or is damaged, is refused by name.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

// The first `n` records of a log (its comment lines, its header line and n records).
void write_head(const std::string& from, const std::string& to, int n) {
  std::istringstream in(test::read_text(from));
  std::ostringstream out;
  std::string line;
  int rows = -1;  // the header is the first line that is not a comment
  while (rows < n && std::getline(in, line)) {
    out << line << "\n";
    if (!line.starts_with("#")) ++rows;
  }
  test::write_text(to, out.str());
}

const char* kFit = " --particles 128 --threads 1 --seed 6 --quiet";

// The one checkpoint file of seed 6 in `dir` (fit.6.KEY.ckpt, KEY from the site), "" if none or several.
std::string checkpoint_in(const std::string& dir) {
  std::vector<std::string> found;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.starts_with("fit.6.") && name.ends_with(".ckpt")) found.push_back(e.path().string());
  }
  return found.size() == 1 ? found.front() : "";
}
}  // namespace

TEST_CASE("fit --checkpoint goes on from a checkpoint, over a log grown since, with the bits of a straight fit",
          "[cli][checkpoint][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv"), head = dir.file("head.csv"), ckpt = dir.file("ckpt");
  REQUIRE(run_ssrfleet("simulate --trucks 70 --seed 2 --quiet --out " + q(log), dir).status == 0);
  write_head(log, head, 40);
  std::filesystem::create_directory(ckpt);
  const auto straight = run_ssrfleet("fit " + q(log) + kFit + " --out " + q(dir.file("straight.json")), dir);
  REQUIRE(straight.status == 0);

  // The first 40 trucks, checkpointed every 15 and after the last.
  const auto first = run_ssrfleet("fit " + q(head) + kFit + " --checkpoint " + q(ckpt) +
                                      " --checkpoint-every-trucks 15 --out " + q(dir.file("head.json")), dir);
  INFO(first.err);
  REQUIRE(first.status == 0);
  REQUIRE_FALSE(checkpoint_in(ckpt).empty());
  // The whole log with the same directory: trucks 41-70 only, then the final sweeps.
  const auto grown = run_ssrfleet("fit " + q(log) + " --particles 128 --threads 2 --seed 6 --checkpoint " + q(ckpt) +
                                      " --out " + q(dir.file("grown.json")), dir);
  INFO(grown.err);
  REQUIRE(grown.status == 0);
  CHECK(grown.err.find("resumed from") != std::string::npos);
  CHECK(grown.err.find("fit: truck 40/70") == std::string::npos);  // not absorbed again
  CHECK(grown.err.find("fit: truck 41/70") != std::string::npos);
  CHECK(test::read_text(dir.file("grown.json")) == test::read_text(dir.file("straight.json")));
  // Run again: the checkpoint after the last truck leaves only the final sweeps, and the same answer.
  const auto again = run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --out " + q(dir.file("again.json")), dir);
  REQUIRE(again.status == 0);
  CHECK(test::read_text(dir.file("again.json")) == test::read_text(dir.file("straight.json")));
}

TEST_CASE("fit --checkpoint refuses a checkpoint of another log, a damaged one, and bad options, by name",
          "[cli][checkpoint]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv"), other = dir.file("other.csv"), ckpt = dir.file("ckpt");
  REQUIRE(run_ssrfleet("simulate --trucks 12 --seed 2 --quiet --out " + q(log), dir).status == 0);
  REQUIRE(run_ssrfleet("simulate --trucks 12 --seed 3 --quiet --out " + q(other), dir).status == 0);
  std::filesystem::create_directory(ckpt);
  REQUIRE(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --out " + q(dir.file("p.json")), dir).status == 0);
  const std::string file = checkpoint_in(ckpt);
  REQUIRE_FALSE(file.empty());

  // Other options that change the run from a state: refused, naming both.
  const auto other_options = run_ssrfleet("fit " + q(log) + " --particles 64 --threads 1 --seed 6 --quiet --checkpoint " +
                                              q(ckpt) + " --out " + q(dir.file("o.json")), dir);
  CHECK(other_options.status == 65);
  CHECK(other_options.err.find("made with particles=128") != std::string::npos);
  CHECK(other_options.err.find("this fit has particles=64") != std::string::npos);

  // Another log with the same ids: its first truck's data differ.
  const auto wrong = run_ssrfleet("fit " + q(other) + kFit + " --checkpoint " + q(ckpt) + " --out " + q(dir.file("w.json")), dir);
  CHECK(wrong.status == 65);
  CHECK(wrong.err.find(file) != std::string::npos);
  CHECK(wrong.err.find("truck 1") != std::string::npos);
  CHECK(wrong.err.find("not the one this checkpoint was made from") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir.file("w.json")));

  // A log shorter than the checkpoint.
  write_head(log, dir.file("short.csv"), 5);
  const auto shorter = run_ssrfleet("fit " + q(dir.file("short.csv")) + kFit + " --checkpoint " + q(ckpt), dir);
  CHECK(shorter.status == 65);
  CHECK(shorter.err.find("holds 12 trucks, the log 5") != std::string::npos);

  // A flipped byte in a truck's record, and a cut file: refused by the file's name, never fitted.
  std::string bytes = test::read_text(file);
  for (const std::size_t at : {bytes.size() / 2, bytes.size() - 3}) {
    std::string damaged = bytes;
    damaged[at] = static_cast<char>(damaged[at] ^ 0x5a);
    test::write_text(file, damaged);
    const auto r = run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --out " + q(dir.file("d.json")), dir);
    INFO(r.err);
    CHECK(r.status == 65);
    CHECK(r.err.find(file) != std::string::npos);
  }
  test::write_text(file, bytes.substr(0, bytes.size() / 3));
  const auto cut = run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --out " + q(dir.file("d.json")), dir);
  CHECK(cut.status == 65);
  CHECK(cut.err.find(file) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir.file("d.json")));

  CHECK(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(dir.file("no/such/folder")), dir).status == 66);
  CHECK(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(log), dir).status == 64);  // a file
  // A missing folder whose parent exists is made.
  CHECK(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(dir.file("new")) + " --out " + q(dir.file("n.json")), dir)
            .status == 0);
  CHECK_FALSE(checkpoint_in(dir.file("new")).empty());
  CHECK(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --checkpoint-every 0", dir).status == 64);
  CHECK(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --method mcmc", dir).status == 64);
  CHECK(run_ssrfleet("fit " + q(log) + kFit + " --checkpoint " + q(ckpt) + " --core latent", dir).status == 64);
}
