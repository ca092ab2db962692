// The site manifest (io/site_manifest.hpp), and each accepted site built from it as `fit --sites`
// and `sites` build it (bin/cli_common: the road, the sensor array, the road covering the sensors).
// Relative paths resolve against a folder made once, holding a.csv and b.csv (any entry's log).
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_common.hpp"
#include "fuzz_support.hpp"
#include "io/site_manifest.hpp"

using namespace ssrfleet;

namespace {
const std::string& folder() {
  static const std::string dir = [] {
    const auto d = std::filesystem::temp_directory_path() / "ssrfleet-fuzz-site-manifest";
    std::filesystem::create_directories(d);
    for (const char* name : {"a.csv", "b.csv"}) std::ofstream(d / name) << "truck_id,speed_mps,sprung_mass_kg,if_1\n";
    return d.string();
  }();
  return dir;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in{std::string(fuzz::as_text(data, size))};
  fuzz::expect_clean("m.json", [&] {
    const io::SiteManifest m = io::read_site_manifest(in, "m.json", folder());
    for (const auto& entry : m.sites) {
      cli::SiteFlags flags;
      cli::site_of_manifest_entry(m, entry, flags, nullptr);
    }
  });
  return 0;
}
