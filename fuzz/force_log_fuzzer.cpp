// The tyre-force log `weigh` reads (io/force_log.hpp), with any sensor count and with the site's 16.
#include <sstream>

#include "fuzz_support.hpp"
#include "io/force_log.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(fuzz::as_text(data, size));
  for (const int sensors : {0, 16}) {
    std::istringstream in(text);
    fuzz::expect_clean("forces.csv", [&] { io::read_force_log(in, "forces.csv", sensors, "(--sensors 76,1.5,16)"); });
  }
  return 0;
}
