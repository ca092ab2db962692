// Small helpers shared by tests: temporary directories, writing files, running the ssrfleet
// binary and capturing its exit status and output.
#pragma once

#include "model/fleet_distribution.hpp"
#include "util/errors.hpp"

#include <cstdlib>
#include <functional>
#include <optional>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace ssrfleet::test {

// The second preset fleet of the benchmarks (benchmarks/fleet_presets.hpp: road AS2, sigma_IF 0.03),
// whose trucks' lateral positions the sensors leave broad and many-peaked.
inline fleet::FleetDistribution second_fleet() {
  fleet::FleetDistribution d;
  d.stiffness_npm = {380e3, 60e3};
  d.tyre_stiffness_npm = {1.6e6, 240e3};
  d.lateral_m = {1.8, 0.35};
  d.sprung_mass_kg = {5200, 600};
  d.speed_mps = {20, 3};
  return d;
}

// A fresh directory under the system temp dir, removed when the object goes away.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() / ("ssrfleet-test-" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct RunResult {
  int status = -1;
  std::string out;
  std::string err;
};

// Runs `ssrfleet <args>` through the shell (args must be shell-quoted by the caller).
inline RunResult run_ssrfleet(const std::string& args, const TempDir& dir) {
  const std::string out = dir.file("stdout.txt"), err = dir.file("stderr.txt");
  const std::string cmd = std::string("'") + SSRFLEET_BINARY + "' " + args + " >'" + out + "' 2>'" + err + "' </dev/null";
  const int raw = std::system(cmd.c_str());
  RunResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

// The DataError f throws, if it throws one (so a test can check its file, line and field).
inline std::optional<DataError> data_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const DataError& e) {
    return e;
  }
  return std::nullopt;
}

}  // namespace ssrfleet::test
