// simulate's truck list (io/truck_list_csv.hpp), on a 0-5 m wide road.
#include <sstream>

#include "fuzz_support.hpp"
#include "io/truck_list_csv.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in{std::string(fuzz::as_text(data, size))};
  fuzz::expect_clean("trucks.csv", [&] { io::read_truck_list(in, "trucks.csv", 0.0, 5.0); });
  return 0;
}
