// Several catalogue effects fitted at once, some of their parameters fixed: the extension a model
// spec such as "tyre_damping+sensor_gain:sensor=11" describes (model_spec.hpp).
//
// ψ of the composition is the free parameters of every component, in spec order; a fixed
// parameter is held at its value and never moves. Each hook hands every component its whole ψ
// (free values from the composition's ψ, fixed ones from the spec), in spec order:
//   edit_pass and edit_output   applied component after component;
//   add_profile                 the components' profiles summed (the system is linear);
//   the stiffness distribution  the one component that replaces it (at most one may);
//   jump                        one component's jump, chosen by a uniform independent of ψ, so
//                               the proposal stays symmetric; a component with a fixed
//                               parameter offers none (its jump could move the fixed value);
//   move coordinates            each component's own when none of its parameters is fixed, ψ
//                               itself otherwise.
// The composition changes no component: with one component and nothing fixed, parse_model_spec
// hands out that component itself, so a single effect fits bit for bit as before.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "model/model_extension.hpp"

namespace ssrfleet::fleet {

struct ExtensionComponent {
  std::unique_ptr<ModelExtension> extension;
  // Per parameter of the component: NaN = free (fitted), a number = fixed at that value.
  std::vector<double> fixed;
};

class ComposedExtension final : public ModelExtension {
 public:
  // spec: the canonical text (name()); components: at least one, at most one that replaces the
  // stiffness distribution (UsageError otherwise).
  ComposedExtension(std::string spec, std::vector<ExtensionComponent> components);

  std::string name() const override { return spec_; }
  std::string description() const override;
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override;

  void edit_pass(const double* psi, PassSetup& pass) const override;
  bool adds_profile() const override;
  void add_profile(const double* psi, double dx_m, Eigen::Ref<Eigen::ArrayXd> profile) const override;
  void edit_output(const double* psi, Eigen::Ref<Eigen::ArrayXd> impact_factor) const override;
  bool edits_forward() const override;

  bool edits_stiffness_distribution() const override { return stiffness_ != nullptr; }
  double log_stiffness_density(const double* psi, double k, double mean_npm, double sd_npm) const override;
  double stiffness_cdf(const double* psi, double k, double mean_npm, double sd_npm) const override;
  std::vector<StiffnessComponent> stiffness_mixture(const double* psi, double mean_npm, double sd_npm) const override;
  double draw_stiffness(const double* psi, double mean_npm, double sd_npm, double uniform,
                        double standard_normal) const override;
  void edit_simulated_truck(const double* psi, records::Truck& truck, double uniform,
                            double standard_normal) const override;

  int jump_draws() const override;
  void jump(const double* psi, const double* u, double* psi_out) const override;
  int stiffness_jump_draws() const override;
  void stiffness_jump(const double* psi, double mean_npm, double sd_npm, const double* u, double* psi_out,
                      double* mean_out, double* sd_out) const override;

  void to_move_coordinates(const double* psi, double* u) const override;
  void from_move_coordinates(const double* u, double* psi) const override;
  double log_move_jacobian(const double* psi) const override;

  // The components in spec order (for reports).
  const std::vector<ExtensionComponent>& components() const { return components_; }

 private:
  // Up to this many parameters per component: the buffers of the hooks live on the stack.
  static constexpr std::size_t kMaxComponentParameters = 8;
  struct Slot {
    const ModelExtension* extension;
    std::size_t offset;      // of its free parameters in the composition's ψ
    std::size_t free_count;  // its free parameters
    bool any_fixed;
  };
  // The component's whole ψ from the composition's ψ.
  void component_psi(std::size_t c, const double* psi, double* out) const;

  std::string spec_;
  std::vector<ExtensionComponent> components_;
  std::vector<Slot> slots_;
  std::vector<ExtensionParameter> params_;
  std::size_t stiffness_index_ = 0;
  const ModelExtension* stiffness_ = nullptr;
  std::vector<std::size_t> jumpers_;  // components whose jump the composition offers
};

}  // namespace ssrfleet::fleet
