#include "model/composed_extension.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

ComposedExtension::ComposedExtension(std::string spec, std::vector<ExtensionComponent> components)
    : spec_(std::move(spec)), components_(std::move(components)) {
  if (components_.empty()) throw UsageError("model '" + spec_ + "': no effect");
  const bool prefixed = components_.size() > 1;
  std::size_t offset = 0;
  for (std::size_t c = 0; c < components_.size(); ++c) {
    const ModelExtension& e = *components_[c].extension;
    const auto& ps = e.parameters();
    if (ps.size() > kMaxComponentParameters || components_[c].fixed.size() != ps.size()) {
      throw UsageError("model '" + spec_ + "': effect " + e.name() + " has an unexpected parameter count");
    }
    Slot slot{&e, offset, 0, false};
    for (std::size_t j = 0; j < ps.size(); ++j) {
      if (std::isnan(components_[c].fixed[j])) {
        ExtensionParameter p = ps[j];
        if (prefixed) p.name = e.name() + "." + p.name;
        params_.push_back(p);
        ++slot.free_count;
      } else {
        slot.any_fixed = true;
      }
    }
    offset += slot.free_count;
    slots_.push_back(slot);
    if (e.edits_stiffness_distribution()) {
      if (stiffness_ != nullptr) {
        throw UsageError("model '" + spec_ + "': " + stiffness_->name() + " and " + e.name() +
                         " both replace the fleet's stiffness distribution; choose one");
      }
      stiffness_ = &e;
      stiffness_index_ = c;
    }
    if (e.jump_draws() > 0 && !slot.any_fixed && slot.free_count > 0) jumpers_.push_back(c);
  }
}

void ComposedExtension::component_psi(std::size_t c, const double* psi, double* out) const {
  const auto& fixed = components_[c].fixed;
  std::size_t next = slots_[c].offset;
  for (std::size_t j = 0; j < fixed.size(); ++j) out[j] = std::isnan(fixed[j]) ? psi[next++] : fixed[j];
}

std::string ComposedExtension::description() const {
  std::string s;
  for (const auto& c : components_) s += (s.empty() ? "" : "; ") + c.extension->description();
  return s;
}

std::vector<CheckKind> ComposedExtension::signature() const {
  std::vector<CheckKind> all;
  for (const auto& c : components_) {
    for (CheckKind k : c.extension->signature()) {
      if (std::find(all.begin(), all.end(), k) == all.end()) all.push_back(k);
    }
  }
  return all;
}

void ComposedExtension::edit_pass(const double* psi, PassSetup& pass) const {
  std::array<double, kMaxComponentParameters> full{};
  for (std::size_t c = 0; c < components_.size(); ++c) {
    component_psi(c, psi, full.data());
    components_[c].extension->edit_pass(full.data(), pass);
  }
}

bool ComposedExtension::adds_profile() const {
  return std::any_of(components_.begin(), components_.end(), [](const auto& c) { return c.extension->adds_profile(); });
}

void ComposedExtension::add_profile(const double* psi, double dx_m, Eigen::Ref<Eigen::ArrayXd> profile) const {
  std::array<double, kMaxComponentParameters> full{};
  for (std::size_t c = 0; c < components_.size(); ++c) {
    if (!components_[c].extension->adds_profile()) continue;
    component_psi(c, psi, full.data());
    components_[c].extension->add_profile(full.data(), dx_m, profile);  // each adds its own height
  }
}

void ComposedExtension::edit_output(const double* psi, Eigen::Ref<Eigen::ArrayXd> impact_factor) const {
  std::array<double, kMaxComponentParameters> full{};
  for (std::size_t c = 0; c < components_.size(); ++c) {
    component_psi(c, psi, full.data());
    components_[c].extension->edit_output(full.data(), impact_factor);
  }
}

bool ComposedExtension::edits_forward() const {
  return std::any_of(components_.begin(), components_.end(), [](const auto& c) { return c.extension->edits_forward(); });
}

double ComposedExtension::log_stiffness_density(const double* psi, double k, double mean_npm, double sd_npm) const {
  if (stiffness_ == nullptr) return ModelExtension::log_stiffness_density(psi, k, mean_npm, sd_npm);
  std::array<double, kMaxComponentParameters> full{};
  component_psi(stiffness_index_, psi, full.data());
  return stiffness_->log_stiffness_density(full.data(), k, mean_npm, sd_npm);
}

double ComposedExtension::stiffness_cdf(const double* psi, double k, double mean_npm, double sd_npm) const {
  if (stiffness_ == nullptr) return ModelExtension::stiffness_cdf(psi, k, mean_npm, sd_npm);
  std::array<double, kMaxComponentParameters> full{};
  component_psi(stiffness_index_, psi, full.data());
  return stiffness_->stiffness_cdf(full.data(), k, mean_npm, sd_npm);
}

std::vector<ModelExtension::StiffnessComponent> ComposedExtension::stiffness_mixture(const double* psi, double mean_npm,
                                                                                    double sd_npm) const {
  if (stiffness_ == nullptr) return ModelExtension::stiffness_mixture(psi, mean_npm, sd_npm);
  std::array<double, kMaxComponentParameters> full{};
  component_psi(stiffness_index_, psi, full.data());
  return stiffness_->stiffness_mixture(full.data(), mean_npm, sd_npm);
}

double ComposedExtension::draw_stiffness(const double* psi, double mean_npm, double sd_npm, double uniform,
                                         double standard_normal) const {
  if (stiffness_ == nullptr) return ModelExtension::draw_stiffness(psi, mean_npm, sd_npm, uniform, standard_normal);
  std::array<double, kMaxComponentParameters> full{};
  component_psi(stiffness_index_, psi, full.data());
  return stiffness_->draw_stiffness(full.data(), mean_npm, sd_npm, uniform, standard_normal);
}

void ComposedExtension::edit_simulated_truck(const double* psi, records::Truck& truck, double uniform,
                                             double standard_normal) const {
  std::array<double, kMaxComponentParameters> full{};
  for (std::size_t c = 0; c < components_.size(); ++c) {
    component_psi(c, psi, full.data());
    components_[c].extension->edit_simulated_truck(full.data(), truck, uniform, standard_normal);
  }
}

int ComposedExtension::jump_draws() const {
  int most = 0;
  for (std::size_t c : jumpers_) most = std::max(most, components_[c].extension->jump_draws());
  return most > 0 ? most + 1 : 0;  // the first uniform picks the component
}

void ComposedExtension::jump(const double* psi, const double* u, double* psi_out) const {
  std::copy(psi, psi + dim(), psi_out);
  if (jumpers_.empty()) return;
  const auto pick = std::min(jumpers_.size() - 1, static_cast<std::size_t>(u[0] * static_cast<double>(jumpers_.size())));
  const std::size_t c = jumpers_[pick];
  std::array<double, kMaxComponentParameters> full{}, jumped{};
  component_psi(c, psi, full.data());
  components_[c].extension->jump(full.data(), u + 1, jumped.data());
  // A jumper has no fixed parameter: its whole ψ is its slice of ours.
  std::copy(jumped.begin(), jumped.begin() + static_cast<std::ptrdiff_t>(slots_[c].free_count), psi_out + slots_[c].offset);
}

int ComposedExtension::stiffness_jump_draws() const {
  if (stiffness_ == nullptr || slots_[stiffness_index_].any_fixed) return 0;
  return stiffness_->stiffness_jump_draws();
}

void ComposedExtension::stiffness_jump(const double* psi, double mean_npm, double sd_npm, const double* u,
                                       double* psi_out, double* mean_out, double* sd_out) const {
  std::copy(psi, psi + dim(), psi_out);
  const Slot& s = slots_[stiffness_index_];
  stiffness_->stiffness_jump(psi + s.offset, mean_npm, sd_npm, u, psi_out + s.offset, mean_out, sd_out);
}

void ComposedExtension::to_move_coordinates(const double* psi, double* u) const {
  for (const Slot& s : slots_) {
    if (s.any_fixed) {
      std::copy(psi + s.offset, psi + s.offset + s.free_count, u + s.offset);
    } else if (s.free_count > 0) {
      s.extension->to_move_coordinates(psi + s.offset, u + s.offset);
    }
  }
}

void ComposedExtension::from_move_coordinates(const double* u, double* psi) const {
  for (const Slot& s : slots_) {
    if (s.any_fixed) {
      std::copy(u + s.offset, u + s.offset + s.free_count, psi + s.offset);
    } else if (s.free_count > 0) {
      s.extension->from_move_coordinates(u + s.offset, psi + s.offset);
    }
  }
}

double ComposedExtension::log_move_jacobian(const double* psi) const {
  double sum = 0.0;
  for (const Slot& s : slots_) {
    if (!s.any_fixed && s.free_count > 0) sum += s.extension->log_move_jacobian(psi + s.offset);
  }
  return sum;
}

}  // namespace ssrfleet::fleet
