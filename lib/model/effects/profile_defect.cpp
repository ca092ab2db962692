// profile_defect: a local bump (height > 0) or dip (< 0) across the whole lane that the road
// file does not have (a patch, a joint, settlement over a culvert). Its shape is a raised
// cosine of the given length centred at `position`, smoothed by the site's tyre envelopment like
// the rest of the road. Its position may be anywhere from 20 m before the first sensor to the
// last sensor: a defect after the last sensor cannot be seen.
#include <algorithm>
#include <cmath>

#include "model/model_extension.hpp"
#include "road/envelopment.hpp"

namespace ssrfleet::fleet {
namespace {

class ProfileDefect final : public ModelExtension {
  static constexpr double kJumpShift = 1.5;  // m
  // The trucks feel a short defect through its size, not its shape: the data pin down about
  // height x length^0.8 and leave the length loose along a curved ridge (50 trucks of the Table 1
  // fleet on AS1, a 0.5 m x 10 mm bump, 25,000 batch MCMC sweeps: log height against log length
  // has slope -0.84; height x length^0.8 varies by 7.5 % where height varies by 41 %, and is
  // nearly uncorrelated with log length, -0.27). Not 1 (the bump's area): the site's envelopment
  // spreads a short bump over its own window, so a shorter one needs less extra height.
  static constexpr double kSizeExponent = 0.8;

 public:
  explicit ProfileDefect(const site::Site& site) : envelopment_m_(site.options().envelopment_m) {
    const auto& x = site.sensor_positions_m();
    const double first = std::max(1.0, x.front() - 20.0);
    params_ = {{"position", "m", first, x.back(), 0.5 * (first + x.back())},
               {"length", "m", 0.1, 2.0, 0.5},
               {"height", "m", -0.03, 0.03, 0.0}};
  }
  std::string name() const override { return "profile_defect"; }
  std::string description() const override { return "a local bump or dip absent from the road file"; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override {
    return {CheckKind::kSensorMean, CheckKind::kSensorDispersion, CheckKind::kAutocorrelation};
  }
  // Alias: the truck answers a short defect with a decaying wheel-hop oscillation (about 2 m long
  // at highway speed), so a dip a fraction of that wavelength downstream of a bump (or the other
  // way round) fits the sensors after it almost as well, and early trucks may prefer it. The jump
  // flips the sign, shifts the position by up to kJumpShift either way and redraws the length
  // from its prior: symmetric, since the reverse jump flips back with the opposite shift.
  int jump_draws() const override { return 2; }
  void jump(const double* psi, const double* u, double* out) const override {
    out[0] = psi[0] + kJumpShift * (2.0 * u[0] - 1.0);
    out[1] = params_[1].lo + (params_[1].hi - params_[1].lo) * u[1];
    out[2] = -psi[2];
  }
  // The walks step in (position, log length, height x length^0.8), where that ridge is straight.
  void to_move_coordinates(const double* psi, double* u) const override {
    u[0] = psi[0];
    u[1] = std::log(psi[1]);
    u[2] = psi[2] * std::pow(psi[1], kSizeExponent);
  }
  void from_move_coordinates(const double* u, double* psi) const override {
    psi[0] = u[0];
    psi[1] = std::exp(u[1]);
    psi[2] = u[2] * std::exp(-kSizeExponent * u[1]);
  }
  // ψ(u) is triangular: ∂length/∂u1 = length, ∂height/∂u2 = length^-0.8.
  double log_move_jacobian(const double* psi) const override { return (1.0 - kSizeExponent) * std::log(psi[1]); }
  bool adds_profile() const override { return true; }
  void add_profile(const double* psi, double dx_m, Eigen::Ref<Eigen::ArrayXd> profile) const override {
    const double centre = psi[0], length = psi[1], height = psi[2];
    const Eigen::Index n = profile.size();
    const double start = centre - 0.5 * length;
    // Raw shape on the samples it covers, then the site's moving average (road/envelopment.hpp)
    // over that stretch only: the rest of the profile is zero, so this is the envelopment of the
    // whole line, at a few dozen samples' cost instead of the road's.
    const Eigen::Index h = (road::envelopment_points(dx_m, envelopment_m_) - 1) / 2;
    const Eigen::Index first = std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::floor(start / dx_m)), 0, n - 1);
    const Eigen::Index last =
        std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::ceil((start + length) / dx_m)), 0, n - 1);
    const Eigen::Index lo = std::max<Eigen::Index>(0, first - h), hi = std::min<Eigen::Index>(n - 1, last + h);
    Eigen::ArrayXd raw = Eigen::ArrayXd::Zero(hi - lo + 1);
    for (Eigen::Index j = first; j <= last; ++j) {
      const double u = (static_cast<double>(j) * dx_m - start) / length;
      if (u > 0.0 && u < 1.0) raw[j - lo] = height * 0.5 * (1.0 - std::cos(2.0 * M_PI * u));
    }
    for (Eigen::Index j = lo; j <= hi; ++j) {
      // The window shrinks symmetrically at the road's ends, as road::envelop does.
      const Eigen::Index w = std::min({h, j, n - 1 - j});
      double sum = 0.0;
      for (Eigen::Index q = j - w; q <= j + w; ++q) sum += (q >= lo && q <= hi) ? raw[q - lo] : 0.0;
      profile[j] += sum / static_cast<double>(2 * w + 1);
    }
  }

 private:
  double envelopment_m_;
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("profile_defect", [](const site::Site& site) { return std::make_unique<ProfileDefect>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
