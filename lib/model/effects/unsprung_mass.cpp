// unsprung_mass: the axle's mass m1 differs from the value the site assumes (420 kg by default).
// It moves the axle-hop frequency, and with it the pattern of dynamic force along the road.
#include "model/effects/vehicle_constant.hpp"

namespace ssrfleet::fleet {
namespace {

const ExtensionRegistrar registrar("unsprung_mass", [](const site::Site& site) {
  return std::make_unique<VehicleConstantExtension>(
      "unsprung_mass", "unsprung mass m1 differs from the assumed value",
      ExtensionParameter{"m1", "kg", 200.0, 1000.0, site.options().unsprung_mass_kg}, &PassSetup::unsprung_mass_kg,
      std::vector<CheckKind>{CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed, CheckKind::kMass,
                             CheckKind::kAutocorrelation});
});

}  // namespace
}  // namespace ssrfleet::fleet
