// tyre_damping: the tyre dissipates energy (c_t > 0, N s/m), which the base model (c_t = the
// site's value, 0 in the paper) leaves out. It damps the axle's hop at 8-12 Hz, so the effect is
// largest where the road excites the axle.
#include "model/effects/vehicle_constant.hpp"

namespace ssrfleet::fleet {
namespace {

const ExtensionRegistrar registrar("tyre_damping", [](const site::Site& site) {
  return std::make_unique<VehicleConstantExtension>(
      "tyre_damping", "tyre damping c_t differs from the assumed value",
      ExtensionParameter{"c_t", "N s/m", 0.0, 10e3, site.options().tyre_damping_nspm}, &PassSetup::tyre_damping_nspm,
      std::vector<CheckKind>{CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed,
                             CheckKind::kAutocorrelation});
});

}  // namespace
}  // namespace ssrfleet::fleet
