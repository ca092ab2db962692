// suspension_damping: the suspension's viscous damping c_b differs from the value the site
// assumes (20 kN s/m by default). It sets how long body bounce rings on after a disturbance.
#include "model/effects/vehicle_constant.hpp"

namespace ssrfleet::fleet {
namespace {

const ExtensionRegistrar registrar("suspension_damping", [](const site::Site& site) {
  return std::make_unique<VehicleConstantExtension>(
      "suspension_damping", "suspension damping c_b differs from the assumed value",
      ExtensionParameter{"c_b", "N s/m", 2e3, 80e3, site.options().suspension_damping_nspm},
      &PassSetup::suspension_damping_nspm,
      std::vector<CheckKind>{CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed, CheckKind::kMass,
                             CheckKind::kAutocorrelation});
});

}  // namespace
}  // namespace ssrfleet::fleet
