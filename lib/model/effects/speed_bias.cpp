// speed_bias: the WIM system's speeds are biased by a factor, logged = b x true, so the car
// really drove at logged / b and the road's wavelengths excite it at other frequencies.
#include "model/model_extension.hpp"

namespace ssrfleet::fleet {
namespace {

class SpeedBias final : public ModelExtension {
 public:
  explicit SpeedBias(const site::Site& /*site*/) { params_ = {{"factor", "", 0.8, 1.25, 1.0}}; }
  std::string name() const override { return "speed_bias"; }
  std::string description() const override { return "logged speeds are biased by a factor"; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override {
    return {CheckKind::kSensorMean, CheckKind::kSpeed, CheckKind::kAutocorrelation};
  }
  void edit_pass(const double* psi, PassSetup& pass) const override { pass.speed_mps /= psi[0]; }

 private:
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("speed_bias", [](const site::Site& site) { return std::make_unique<SpeedBias>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
