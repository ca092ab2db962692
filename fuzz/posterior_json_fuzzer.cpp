// The posterior file (io/posterior_json.hpp) that predict, damage and weigh read.
#include <sstream>

#include "fuzz_support.hpp"
#include "io/posterior_json.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in{std::string(fuzz::as_text(data, size))};
  fuzz::expect_clean("posterior.json", [&] {
    const fleet::PosteriorCloud cloud = io::read_posterior(in, "posterior.json");
    if (cloud.theta.cols() != cloud.weights.size()) std::abort();
  });
  return 0;
}
