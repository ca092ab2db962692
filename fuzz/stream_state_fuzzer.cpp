// A stream's state files (stream/wim_stream.hpp) as a resume reads them: checkpoint.bin (the
// stream's bookkeeping, then the core's checkpoint: fleet/marginal_smc.cpp with
// fleet/marginal_target_checkpoint.cpp, or fleet/fleet_smc.cpp with fleet/fleet_target.cpp) and,
// for the marginal core, the truck log trucks.bin. The harness writes them into a state directory
// of its own and constructs the stream on it, exactly as `ssrfleet stream --state DIR` does.
//
// Input: one byte choosing the core (even: marginal, odd: latent with --window 5), a 4-byte
// little-endian length L, L bytes of checkpoint.bin, the rest trucks.bin. The options are those of
// the seed corpus: ssrfleet stream --road AS1 --particles 16 --threads 1 --seed 1 [--window 5].
//
// The seeds are real states, made by this harness so that site and options match:
//   SSRFLEET_FUZZ_MAKE_SEEDS=fuzz/corpus/stream_state build-fuzz/fuzz/stream_state_fuzzer -runs=0
// streams 3 simulated trucks into a state on each core and writes marginal.bin and latent.bin;
//   SSRFLEET_FUZZ_CHECK_SEEDS=fuzz/corpus/stream_state build-fuzz/fuzz/stream_state_fuzzer -runs=0
// resumes from each seed and exits 1 naming any that fails (CTest fuzz:stream_state-seeds-resume).
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "fleet/simulator.hpp"
#include "io/wim_log.hpp"
#include "model/fleet_distribution.hpp"
#include "fuzz_support.hpp"
#include "site/road_source.hpp"
#include "stream/wim_stream.hpp"

using namespace ssrfleet;
namespace fs = std::filesystem;

namespace {
const site::Site& default_site() {
  static const site::Site site(site::load_road("AS1"), cli::SiteFlags{}.to_options());
  return site;
}

const std::string& state_dir() {
  static const std::string dir = [] {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/ssrfleet-fuzz-state-XXXXXX";
    if (!mkdtemp(pattern.data())) std::abort();
    return pattern;
  }();
  return dir;
}

stream::StreamOptions options_for(bool latent, const std::string& dir) {
  stream::StreamOptions options;
  options.state_dir = dir;
  if (latent) {
    options.fit.core = fleet::OnlineFitOptions::Core::kLatent;
    options.fit.latent.window = 5;
  }
  options.fit.sampler().particles = 16;
  options.fit.sampler().threads = 1;
  options.fit.sampler().seed = 1;
  return options;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream all;
  all << in.rdbuf();
  return all.str();
}

void write_bytes(const std::string& path, std::string_view bytes);

// A real state of 3 trucks on each core, in the harness's input layout.
void make_seeds(const std::string& out_dir) {
  const site::Site& site = default_site();
  const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 3, site.lateral_min_m(), site.lateral_max_m(), 7);
  std::ostringstream log;
  io::write_wim_log(log, fleet::simulate_log(site, trucks, 0.02, 7).records);
  for (const bool latent : {false, true}) {
    const std::string dir = state_dir() + (latent ? "/seed-latent" : "/seed-marginal");
    fs::remove_all(dir);
    {
      std::ostringstream reports;
      stream::WimStream stream(site, options_for(latent, dir), nullptr, reports);
      std::istringstream in(log.str());
      const std::atomic<bool> stop{false};
      stream.run(in, "log.csv", stop);
    }
    const std::string checkpoint = read_bytes(dir + "/checkpoint.bin");
    const std::string trucks_bin = latent ? "" : read_bytes(dir + "/trucks.bin");
    std::string input(1, latent ? '\x01' : '\x00');
    const auto length = static_cast<std::uint32_t>(checkpoint.size());
    input.append(reinterpret_cast<const char*>(&length), 4);
    input += checkpoint + trucks_bin;
    write_bytes(out_dir + (latent ? "/latent.bin" : "/marginal.bin"), input);
  }
}

void write_bytes(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) std::abort();
}

// Resumes a stream from one harness input (the checkpoint and trucks.bin it carries). Throws what the
// resume throws.
void resume_from(std::string_view input);

// Every seed in `dir` must get through the readers the harness fuzzes: a seed they reject (the
// checkpoint format moved on since it was made) leaves the campaign fuzzing the rejection alone. It
// happened: stale seeds reached 1,567 edges, fresh ones 2,277. The input carries no history
// database, so a resume that read checkpoint.bin and trucks.bin stops at the history's check
// (stream/wim_stream.cpp, open_history): that, and only that, error is a pass. Exits 1 naming the
// stale seed.
void check_seeds(const std::string& dir) {
  int checked = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string bytes = read_bytes(entry.path().string());
    try {
      try {
        resume_from(bytes);
      } catch (const DataError& e) {
        if (std::string_view(e.what()).find("history.sqlite") == std::string_view::npos) throw;
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "stale seed %s: a resume from it fails: %s\n(remake the seeds: SSRFLEET_FUZZ_MAKE_SEEDS=%s)\n",
                   entry.path().c_str(), e.what(), dir.c_str());
      std::exit(1);
    }
    ++checked;
  }
  std::fprintf(stderr, "%d seeds in %s resume\n", checked, dir.c_str());
  std::exit(checked > 0 ? 0 : 1);
}
}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  state_dir();
  // Registered after the directory's name is made, so it runs before that string is destroyed.
  std::atexit([] {
    std::error_code ignored;
    fs::remove_all(state_dir(), ignored);
  });
  if (const char* out = std::getenv("SSRFLEET_FUZZ_MAKE_SEEDS")) make_seeds(out);
  if (const char* seeds = std::getenv("SSRFLEET_FUZZ_CHECK_SEEDS")) check_seeds(seeds);
  return 0;
}

namespace {
void resume_from(std::string_view input) {
  if (input.size() < 5) throw UsageError("a harness input has at least 5 bytes");
  const bool latent = (input[0] & 1) != 0;
  std::uint32_t length = 0;
  std::memcpy(&length, input.data() + 1, 4);
  const std::string_view rest = input.substr(5);
  const std::string_view checkpoint = rest.substr(0, length);
  const std::string_view trucks = rest.substr(checkpoint.size());

  const std::string& dir = state_dir();
  fs::remove(fs::path(dir) / "rejects.csv");
  write_bytes((fs::path(dir) / "checkpoint.bin").string(), checkpoint);
  if (latent) {
    fs::remove(fs::path(dir) / "trucks.bin");
  } else {
    write_bytes((fs::path(dir) / "trucks.bin").string(), trucks);
  }

  const stream::StreamOptions options = options_for(latent, dir);
  std::ostringstream reports;
  stream::WimStream resumed(default_site(), options, nullptr, reports);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 5) return 0;
  // The messages name the state files by their paths in the state directory.
  fuzz::expect_clean(state_dir(), [&] { resume_from(fuzz::as_text(data, size)); });
  return 0;
}
