// UMTRI ERD longitudinal profiles (road/erd_format.hpp).
#include "fuzz_support.hpp"
#include "road/erd_format.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::expect_clean("road.erd", [&] { road::read_erd(fuzz::as_text(data, size), "road.erd"); });
  return 0;
}
