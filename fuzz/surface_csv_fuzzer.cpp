// The road CSV (road/surface_csv.hpp) that --road FILE.csv reads.
#include <sstream>

#include "fuzz_support.hpp"
#include "road/surface_csv.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in{std::string(fuzz::as_text(data, size))};
  fuzz::expect_clean("road.csv", [&] {
    const road::Surface s = road::read_surface_csv(in, "road.csv");
    if (s.samples() < 2 || s.lines() < 2 || !(s.dx_m > 0.0) || !(s.dy_m > 0.0)) std::abort();
  });
  return 0;
}
