// The forward model with an optional extension (model_extension.hpp): passes whose vehicle
// constants and speed may differ from pass to pass, a height profile added per ψ, and the
// sensors' output edited. With no extension it is exactly Site::impact_factors.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "model/model_extension.hpp"
#include "site/site.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::fleet {

struct ExtendedPass {
  PassSetup setup;              // before the extension's edit_pass
  const double* psi = nullptr;  // the extension's parameters for this pass (ignored without one)
};

// The base model's inputs for one pass: the record's speed and sprung mass, the truck's latents,
// and the site's vehicle constants.
PassSetup base_pass(const site::Site& site, double speed_mps, double sprung_mass_kg, double stiffness_npm,
                    double tyre_stiffness_npm, double lateral_m);

// The quarter car a pass drives (its vehicle constants; speed and lateral position are the pass's own).
vehicle::QuarterCar quarter_car_of(const PassSetup& pass);

// Model impact factors at the site's sensors, sensors x passes, through the batched integrator.
// Passes that share a psi pointer share one added profile, so callers should point passes of
// the same parameters at the same storage. extension may be null; one that edits no pass
// (ModelExtension::edits_forward() false) is the base model here.
// min_if (if given) gets each pass's minimum IF over the road with the extension's pass edits but
// without an added profile (a defect's own dip is not in it).
// integrator: one built for other output positions on the site's surface (predict anywhere);
// null = the site's own (its sensors).
void simulate_passes(const site::Site& site, const ModelExtension* extension, const std::vector<ExtendedPass>& passes,
                     Eigen::Ref<Eigen::ArrayXXd> if_out, Eigen::ArrayXd* min_if = nullptr,
                     const vehicle::PassIntegrator* integrator = nullptr);

}  // namespace ssrfleet::fleet
