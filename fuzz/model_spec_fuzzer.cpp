// Model and effect specs (model/model_spec.hpp): --model for fit/stream/predict, --effect for
// simulate (every parameter given), on the default site (AS1, 16 sensors). Errors are UsageErrors.
#include <string>

#include "fuzz_support.hpp"
#include "model/model_spec.hpp"
#include "road/surface_presets.hpp"
#include "site/site.hpp"

using namespace ssrfleet;

namespace {
const site::Site& default_site() {
  static const site::Site site(road::preset_surface("AS1"), site::SiteOptions{});
  return site;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(fuzz::as_text(data, size));
  const site::Site& site = default_site();
  fuzz::expect_clean("", [&] {
    const fleet::ModelSpec spec = fleet::parse_model_spec(text, site);
    // The canonical text is what files record and parse again: it must read back to itself.
    if (fleet::parse_model_spec(spec.text, site).text != spec.text) std::abort();
  });
  fuzz::expect_clean("", [&] { fleet::parse_simulation_model(text, site); });
  return 0;
}
