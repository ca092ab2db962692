// unsprung_mass: the axle's mass m1 differs from the value the site assumes (420 kg by default).
// It moves the axle-hop frequency, and with it the pattern of dynamic force along the road.
#include "fleet/model_extension.hpp"

namespace ssrfleet::fleet {
namespace {

class UnsprungMass final : public ModelExtension {
 public:
  explicit UnsprungMass(const site::Site& site) {
    params_ = {{"m1", "kg", 200.0, 1000.0, site.options().unsprung_mass_kg}};
  }
  std::string name() const override { return "unsprung_mass"; }
  std::string description() const override { return "unsprung mass m1 differs from the assumed value"; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override {
    return {CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed, CheckKind::kMass,
            CheckKind::kAutocorrelation};
  }
  void edit_pass(const double* psi, PassSetup& pass) const override { pass.unsprung_mass_kg = psi[0]; }

 private:
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("unsprung_mass", [](const site::Site& site) { return std::make_unique<UnsprungMass>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
