// suspension_damping: the suspension's viscous damping c_b differs from the value the site
// assumes (20 kN s/m by default). It sets how long body bounce rings on after a disturbance.
#include "fleet/model_extension.hpp"

namespace ssrfleet::fleet {
namespace {

class SuspensionDamping final : public ModelExtension {
 public:
  explicit SuspensionDamping(const site::Site& site) {
    params_ = {{"c_b", "N s/m", 2e3, 80e3, site.options().suspension_damping_nspm}};
  }
  std::string name() const override { return "suspension_damping"; }
  std::string description() const override { return "suspension damping c_b differs from the assumed value"; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override {
    return {CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed, CheckKind::kMass,
            CheckKind::kAutocorrelation};
  }
  void edit_pass(const double* psi, PassSetup& pass) const override { pass.suspension_damping_nspm = psi[0]; }

 private:
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("suspension_damping",
                                   [](const site::Site& site) { return std::make_unique<SuspensionDamping>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
