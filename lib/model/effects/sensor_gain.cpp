// sensor_gain: one sensor's calibration gain is not 1, so it reports g times the true impact
// factor. Which sensor is inferred too: `sensor` is continuous on [0.5, M + 0.5] and the sensor
// is its nearest integer, so the random walk can jump between sensors.
#include <algorithm>
#include <cmath>

#include "model/model_extension.hpp"

namespace ssrfleet::fleet {
namespace {

class SensorGain final : public ModelExtension {
 public:
  explicit SensorGain(const site::Site& site) : sensors_(site.sensors()) {
    params_ = {{"sensor", "", 0.5, sensors_ + 0.5, 1.0}, {"gain", "", 0.8, 1.2, 1.0}};
  }
  std::string name() const override { return "sensor_gain"; }
  std::string description() const override { return "one sensor's calibration gain differs from 1"; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override { return {CheckKind::kSensorMean, CheckKind::kSensorDispersion}; }
  int sensor_parameter() const override { return 0; }
  void edit_output(const double* psi, Eigen::Ref<Eigen::ArrayXd> impact_factor) const override {
    impact_factor[sensor_index(psi[0])] *= psi[1];
  }

 private:
  Eigen::Index sensor_index(double sensor) const {
    return std::clamp(static_cast<Eigen::Index>(std::lround(sensor)) - 1, Eigen::Index{0}, Eigen::Index{sensors_ - 1});
  }
  int sensors_;
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("sensor_gain", [](const site::Site& site) { return std::make_unique<SensorGain>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
