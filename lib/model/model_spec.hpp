// The model a command fits, predicts with or simulates, as users write it:
// "base", or catalogue effects joined by '+', each in the grammar of simulate --effect,
// NAME[:param=value,...]: a parameter given is fixed at its value, one left out is fitted.
//   tyre_damping+sensor_gain:sensor=11     tyre damping fitted, a gain on sensor 11 fitted
//   sensor_gain:sensor=5,gain=1.05         nothing fitted: the effect known
// Every error is a UsageError that names the bad part and lists the catalogue with each effect's
// parameters and ranges, so the user can correct the spec without the manual.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "model/model_extension.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

struct ModelSpec {
  // Null for the base model; with one effect and nothing fixed, the catalogue's own extension;
  // otherwise a ComposedExtension (composed_extension.hpp).
  std::unique_ptr<ModelExtension> extension;
  // The canonical spec ("base", or the effects in the order given, fixed parameters in the
  // effect's own order): what posterior files and stream states record, and parse again.
  std::string text = "base";
  bool is_base() const { return extension == nullptr; }
};

// "" and "base" are the base model. site: the site the model is for (priors such as the sensor
// range depend on it, so sensor 17 on a 16-sensor site is out of range).
ModelSpec parse_model_spec(const std::string& text, const site::Site& site);

// For simulation, where every parameter must be given: the extension and ψ of the spec (an
// empty ψ for a spec whose parameters are all fixed, which is what this requires). UsageError
// naming the parameters left out.
struct SimulationModel {
  std::unique_ptr<ModelExtension> extension;  // null for the base model
  std::vector<double> psi;
  std::string text = "base";
};
SimulationModel parse_simulation_model(const std::string& text, const site::Site& site);

// One line per catalogue effect: "  name: description; param [lo, hi], ..." for error messages
// and --help.
std::string model_catalogue(const site::Site& site);

}  // namespace ssrfleet::fleet
