// What of a fitted model's effects a prediction of the tyre forces keeps (predict uses
// the extended posterior; predict and damage use this view, weigh the whole model, since the
// forces it weighs went through the sensors). The force the road feels:
//   - the vehicle and the traffic (edit_pass: damping, unsprung mass, the true speed behind a
//     biased logged one) are kept, on every road;
//   - a height the road file lacks (add_profile: profile_defect) is kept on the road it was
//     fitted on only: another road does not have that defect;
//   - what the sensors report (edit_output: a calibration gain) is dropped: it is the instrument,
//     not the force. Its being fitted is what keeps θ, and so the prediction, unbiased;
//   - a replaced stiffness distribution (second_class) is the fleet's and is kept; predict_ssr
//     draws k from it.
#pragma once

#include "model/model_extension.hpp"

namespace ssrfleet::fleet {

class PhysicalEffects final : public ModelExtension {
 public:
  // inner: the fitted model's extension (outlives this); on_fitted_road: the prediction's site is
  // the one the posterior was fitted on.
  PhysicalEffects(const ModelExtension& inner, bool on_fitted_road) : inner_(inner), on_fitted_road_(on_fitted_road) {}

  std::string name() const override { return inner_.name(); }
  std::string description() const override { return inner_.description(); }
  const std::vector<ExtensionParameter>& parameters() const override { return inner_.parameters(); }
  std::vector<CheckKind> signature() const override { return inner_.signature(); }

  void edit_pass(const double* psi, PassSetup& pass) const override { inner_.edit_pass(psi, pass); }
  bool adds_profile() const override { return on_fitted_road_ && inner_.adds_profile(); }
  void add_profile(const double* psi, double dx_m, Eigen::Ref<Eigen::ArrayXd> profile) const override {
    if (adds_profile()) inner_.add_profile(psi, dx_m, profile);
  }
  bool edits_forward() const override { return inner_.edits_forward(); }

  bool edits_stiffness_distribution() const override { return inner_.edits_stiffness_distribution(); }
  double draw_stiffness(const double* psi, double mean_npm, double sd_npm, double uniform,
                        double standard_normal) const override {
    return inner_.draw_stiffness(psi, mean_npm, sd_npm, uniform, standard_normal);
  }
  double log_stiffness_density(const double* psi, double k, double mean_npm, double sd_npm) const override {
    return inner_.log_stiffness_density(psi, k, mean_npm, sd_npm);
  }
  double stiffness_cdf(const double* psi, double k, double mean_npm, double sd_npm) const override {
    return inner_.stiffness_cdf(psi, k, mean_npm, sd_npm);
  }
  std::vector<StiffnessComponent> stiffness_mixture(const double* psi, double mean_npm, double sd_npm) const override {
    return inner_.stiffness_mixture(psi, mean_npm, sd_npm);
  }

 private:
  const ModelExtension& inner_;
  bool on_fitted_road_;
};

}  // namespace ssrfleet::fleet
