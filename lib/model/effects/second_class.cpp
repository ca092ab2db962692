// second_class: the fleet is two classes of truck, the second (a share w of the trucks, e.g. air
// instead of steel suspensions) with its own suspension stiffness distribution N(K2, σ_k2²):
//   k ~ (1 - w) N(K, σ_k²) + w N(K2, σ_k2²).
// It changes the fleet model only; the quarter car is the base model's. w ≤ 0.5 names the second
// class as the minority, which keeps the two classes from swapping labels.
#include <algorithm>
#include <cmath>

#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"

namespace ssrfleet::fleet {
namespace {

enum : int { kShare = 0, kMean2, kSd2 };

class SecondClass final : public ModelExtension {
 public:
  explicit SecondClass(const site::Site& /*site*/) {
    // The class's stiffness prior is the base model's for K and σ_k (docs/model.md). At share 0 the
    // extension is the base model whatever K2 and σ_k2 are; their null values are Table 1's.
    const PriorBounds base;
    params_ = {{"share", "", 0.0, 0.5, 0.0},
               {"K2", "N/m", base.lo[kK], base.hi[kK], 500e3},
               {"sigma_k2", "N/m", base.lo[kSigmaK], base.hi[kSigmaK], 50e3}};
  }
  std::string name() const override { return "second_class"; }
  std::string description() const override {
    return "a second class of trucks with its own suspension stiffness distribution";
  }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  // Each truck's own k absorbs a wrong fleet distribution, so the residuals show nothing; the
  // trucks' fitted stiffnesses do not look like draws from N(K, σ_k²).
  std::vector<CheckKind> signature() const override { return {CheckKind::kStiffnessDistribution}; }
  bool edits_forward() const override { return false; }

  bool edits_stiffness_distribution() const override { return true; }
  double log_stiffness_density(const double* psi, double k, double mean_npm, double sd_npm) const override {
    const double first = log_normal_density(k, mean_npm, sd_npm);
    if (psi[kShare] <= 0.0) return first;
    const double a = std::log1p(-psi[kShare]) + first;
    const double b = std::log(psi[kShare]) + log_normal_density(k, psi[kMean2], psi[kSd2]);
    const double top = std::max(a, b);
    return top + std::log(std::exp(a - top) + std::exp(b - top));
  }
  double stiffness_cdf(const double* psi, double k, double mean_npm, double sd_npm) const override {
    return (1.0 - psi[kShare]) * normal_cdf((k - mean_npm) / sd_npm) + psi[kShare] * normal_cdf((k - psi[kMean2]) / psi[kSd2]);
  }
  std::vector<StiffnessComponent> stiffness_mixture(const double* psi, double mean_npm, double sd_npm) const override {
    if (psi[kShare] <= 0.0) return {{1.0, mean_npm, sd_npm}};
    return {{1.0 - psi[kShare], mean_npm, sd_npm}, {psi[kShare], psi[kMean2], psi[kSd2]}};
  }
  double draw_stiffness(const double* psi, double mean_npm, double sd_npm, double uniform,
                        double standard_normal) const override {
    return uniform < psi[kShare] ? psi[kMean2] + psi[kSd2] * standard_normal : mean_npm + sd_npm * standard_normal;
  }
  // The classes trade places: (K, σ_k) <-> (K2, σ_k2), with the share drawn afresh from its box
  // (symmetric: the reverse trade draws the old share with the same density). The box w <= 0.5
  // makes the label-swapped fit a distinct mode, the stiff class the broad majority at a share
  // near 0.5, which the random walk cannot leave for the other (50 trucks, 17 of them stiff: one
  // of two latent SMC runs kept 10 % of its weight there, K 538k against 497k).
  int stiffness_jump_draws() const override { return 1; }
  void stiffness_jump(const double* psi, double mean_npm, double sd_npm, const double* u, double* psi_out,
                      double* mean_out, double* sd_out) const override {
    psi_out[kShare] = params_[kShare].lo + (params_[kShare].hi - params_[kShare].lo) * u[0];
    psi_out[kMean2] = mean_npm;
    psi_out[kSd2] = sd_npm;
    *mean_out = psi[kMean2];
    *sd_out = psi[kSd2];
  }
  void edit_simulated_truck(const double* psi, records::Truck& truck, double uniform, double standard_normal) const override {
    if (uniform >= psi[kShare]) return;
    // A non-physical draw (possible only when σ_k2 is a large part of K2) keeps the base class's k.
    const double k = psi[kMean2] + psi[kSd2] * standard_normal;
    if (k > 0.0) truck.stiffness_npm = k;
  }

 private:
  std::vector<ExtensionParameter> params_;
};

const ExtensionRegistrar registrar("second_class", [](const site::Site& site) { return std::make_unique<SecondClass>(site); });

}  // namespace
}  // namespace ssrfleet::fleet
