// The shape shared by extensions that replace one vehicle constant the site assumes (c_t, m1,
// c_b) with a fitted value: one parameter, a uniform prior, one field of the pass set.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "model/model_extension.hpp"

namespace ssrfleet::fleet {

class VehicleConstantExtension : public ModelExtension {
 public:
  VehicleConstantExtension(std::string name, std::string description, ExtensionParameter parameter,
                           double PassSetup::*field, std::vector<CheckKind> signature)
      : name_(std::move(name)), description_(std::move(description)), params_{std::move(parameter)}, field_(field),
        signature_(std::move(signature)) {}
  std::string name() const override { return name_; }
  std::string description() const override { return description_; }
  const std::vector<ExtensionParameter>& parameters() const override { return params_; }
  std::vector<CheckKind> signature() const override { return signature_; }
  void edit_pass(const double* psi, PassSetup& pass) const override { pass.*field_ = psi[0]; }

 private:
  std::string name_, description_;
  std::vector<ExtensionParameter> params_;
  double PassSetup::*field_;
  std::vector<CheckKind> signature_;
};

}  // namespace ssrfleet::fleet
