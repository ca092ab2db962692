// OpenCRG (road/crg_header.hpp, road/crg_reader.hpp): the clear-text header, then the text or
// binary payload of any of the four data types.
#include "fuzz_support.hpp"
#include "road/crg_reader.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::expect_clean("road.crg", [&] {
    const road::CrgRoad road = road::read_crg(fuzz::as_text(data, size), "road.crg");
    if (road.surface.samples() < 2 || road.surface.lines() < 2) std::abort();
  });
  return 0;
}
