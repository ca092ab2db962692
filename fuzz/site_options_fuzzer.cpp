// The site and position options of the command line (bin/cli_common.hpp): --sensors
// FIRST,SPACING,COUNT, --positions (a list or FIRST:STEP:LAST), --seed. The input's lines are the
// three option values in turn.
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "fuzz_support.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in{std::string(fuzz::as_text(data, size))};
  std::string sensors, positions, seed;
  std::getline(in, sensors);
  std::getline(in, positions);
  std::getline(in, seed);
  fuzz::expect_clean("", [&] {
    cli::SiteFlags flags;
    flags.sensors = sensors;
    // The positions are what a site builds first: an accepted count must not be an absurd allocation.
    flags.to_options().sensors.positions_m();
  });
  fuzz::expect_clean("", [&] { cli::parse_positions(positions); });
  fuzz::expect_clean("", [&] { cli::parse_seed(seed); });
  return 0;
}
