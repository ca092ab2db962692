#include "model/extended_forward.hpp"

#include <map>

namespace ssrfleet::fleet {

vehicle::QuarterCar quarter_car_of(const PassSetup& s) {
  vehicle::QuarterCar car;
  car.sprung_mass_kg = s.sprung_mass_kg;
  car.unsprung_mass_kg = s.unsprung_mass_kg;
  car.suspension_stiffness_npm = s.stiffness_npm;
  car.suspension_damping_nspm = s.suspension_damping_nspm;
  car.tyre_stiffness_npm = s.tyre_stiffness_npm;
  car.tyre_damping_nspm = s.tyre_damping_nspm;
  return car;
}

PassSetup base_pass(const site::Site& site, double speed_mps, double sprung_mass_kg, double stiffness_npm,
                    double tyre_stiffness_npm, double lateral_m) {
  const auto& o = site.options();
  PassSetup p;
  p.speed_mps = speed_mps;
  p.sprung_mass_kg = sprung_mass_kg;
  p.unsprung_mass_kg = o.unsprung_mass_kg;
  p.stiffness_npm = stiffness_npm;
  p.suspension_damping_nspm = o.suspension_damping_nspm;
  p.tyre_stiffness_npm = tyre_stiffness_npm;
  p.tyre_damping_nspm = o.tyre_damping_nspm;
  p.lateral_m = lateral_m;
  return p;
}

void simulate_passes(const site::Site& site, const ModelExtension* extension, const std::vector<ExtendedPass>& passes,
                     Eigen::Ref<Eigen::ArrayXXd> if_out, Eigen::ArrayXd* min_if,
                     const vehicle::PassIntegrator* other_integrator) {
  const auto n = static_cast<Eigen::Index>(passes.size());
  if (n == 0) return;
  if (extension != nullptr && !extension->edits_forward()) extension = nullptr;  // e.g. second_class
  vehicle::QuarterCarBatch cars;
  cars.assign(n, vehicle::QuarterCar{});
  Eigen::ArrayXd speed(n);
  std::vector<vehicle::WheelPath> paths;
  paths.reserve(passes.size());
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& pass = passes[static_cast<std::size_t>(i)];
    PassSetup s = pass.setup;
    if (extension != nullptr) extension->edit_pass(pass.psi, s);
    cars.set_car(i, quarter_car_of(s));
    speed[i] = s.speed_mps;
    paths.push_back(site.wheel_path(s.lateral_m));
  }
  const auto& integrator = other_integrator != nullptr ? *other_integrator : site.integrator();
  integrator.run_batch(cars, speed, paths, if_out, min_if);
  if (extension == nullptr) return;

  if (extension->adds_profile()) {
    // The quarter car is linear and starts at rest on the profile's first sample, so the added
    // height's effect is its own pass over that height alone (IF - 1), added to the road's.
    std::map<const double*, Eigen::ArrayXd> profiles;
    for (const auto& pass : passes) {
      auto [it, fresh] = profiles.try_emplace(pass.psi);
      if (fresh) {
        it->second = Eigen::ArrayXd::Zero(integrator.samples());
        extension->add_profile(pass.psi, integrator.dx_m(), it->second);
      }
    }
    for (std::size_t i = 0; i < passes.size(); ++i) {
      const double* line = profiles.at(passes[i].psi).data();
      paths[i] = {line, line, 0.0};
    }
    Eigen::ArrayXXd added(if_out.rows(), n);
    integrator.run_batch(cars, speed, paths, added);
    if_out += added - 1.0;
  }
  for (Eigen::Index i = 0; i < n; ++i) extension->edit_output(passes[static_cast<std::size_t>(i)].psi, if_out.col(i));
}

}  // namespace ssrfleet::fleet
