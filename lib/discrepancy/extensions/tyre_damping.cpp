// tyre_damping: the tyre dissipates energy (c_t > 0, N s/m), which the base model (c_t = the
// site's value, 0 in the paper) leaves out. It damps the axle's hop at 8-12 Hz, so the effect is
// largest where the road excites the axle.
#include "fleet/model_extension.hpp"

namespace ssrfleet::fleet {
namespace {

class TyreDamping final : public ModelExtension {
 public:
  explicit TyreDamping(const site::Site& site) {
    params_ = {{"c_t", "N s/m", 0.0, 10e3, site.options().tyre_damping_nspm}};
  }
  std::string name() const override { return "tyre_damping"; }
  std::string description() const override { return "tyre damping c_t differs from the assumed value"; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override {
    return {CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kSpeed, CheckKind::kAutocorrelation};
  }
  void edit_pass(const double* psi, PassSetup& pass) const override { pass.tyre_damping_nspm = psi[0]; }

 private:
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("tyre_damping", [](const site::Site& site) { return std::make_unique<TyreDamping>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
