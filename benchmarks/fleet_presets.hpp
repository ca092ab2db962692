// The simulated fleets the accuracy, coverage and ratio benchmarks fit: the
// paper's Table 1 fleet, and a second one whose hyperparameters, road and noise all differ from
// Table 1's, so that a sampler tuned (knowingly or not) to the paper's case would show it. A
// preset knows the generating parameters, which are the "truth" a posterior is judged against.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "site/site.hpp"

namespace ssrfleet::bench {

struct FleetPreset {
  std::string name;         // as given to --fleet
  std::string description;  // one line for the reports
  std::string road;         // road::preset_surface name
  fleet::FleetDistribution distribution;
  double sigma_if = 0.0;    // measurement noise sd of the impact factors

  // The generating distribution's parameters in fleet_model.hpp order. z is drawn from
  // N(Z, sigma_z²) truncated to the road, which is the model's own form, so Z and sigma_z are the
  // untruncated normal's parameters, as the model's are.
  fleet::HyperVector truth() const {
    const auto& d = distribution;
    return {d.stiffness_npm.mean, d.stiffness_npm.sd, d.tyre_stiffness_npm.mean, d.tyre_stiffness_npm.sd,
            d.lateral_m.mean, d.lateral_m.sd, sigma_if};
  }
};

inline FleetPreset table1_fleet() {
  return {"table1", "Table 1 fleet (FleetDistribution defaults)", "AS1", fleet::FleetDistribution{}, 0.02};
}

// Every hyperparameter moved well away from Table 1 (softer, wider suspension; stiffer-spread
// tyres; trucks further right and closer together; heavier, slower trucks), on another road and
// with more noise.
inline FleetPreset second_fleet() {
  fleet::FleetDistribution d;
  d.stiffness_npm = {380e3, 60e3};
  d.tyre_stiffness_npm = {1.60e6, 240e3};
  d.lateral_m = {1.8, 0.35};
  d.sprung_mass_kg = {5200.0, 600.0};
  d.speed_mps = {20.0, 3.0};
  return {"second", "second fleet (K 380k sd 60k, Kt 1.60M sd 240k, Z 1.8 sd 0.35, mass 5200 sd 600, speed 20 sd 3)",
          "AS2", d, 0.03};
}

// The preset called `name`, or nothing if there is none or its truth lies outside the prior box
// (a truth the prior excludes could never be covered, and the benchmark would measure nothing).
inline std::optional<FleetPreset> find_fleet_preset(const std::string& name) {
  for (const FleetPreset& p : {table1_fleet(), second_fleet()})
    if (p.name == name && fleet::PriorBounds{}.contains(p.truth())) return p;
  return std::nullopt;
}

inline const char* fleet_preset_names() { return "table1|second"; }

// The data of one replicate: the fleet draw and the noise both from `data_seed` (the simulator
// keeps the two streams independent).
inline fleet::SimulatedLog simulate_preset(const site::Site& site, const FleetPreset& preset, int trucks,
                                           std::uint64_t data_seed) {
  const std::vector<records::Truck> drawn =
      fleet::draw_fleet(preset.distribution, trucks, site.lateral_min_m(), site.lateral_max_m(), data_seed);
  return fleet::simulate_log(site, drawn, preset.sigma_if, data_seed);
}

inline nlohmann::json preset_json(const FleetPreset& p) {
  const auto normal = [](const fleet::Normal& n) { return nlohmann::json{{"mean", n.mean}, {"sd", n.sd}}; };
  nlohmann::json truth = nlohmann::json::object();
  const fleet::HyperVector t = p.truth();
  for (int h = 0; h < fleet::kHyperCount; ++h) truth[std::string(fleet::kHyperNames[h])] = t[static_cast<std::size_t>(h)];
  return {{"name", p.name},
          {"description", p.description},
          {"road", p.road},
          {"sigma_if", p.sigma_if},
          {"distribution",
           {{"stiffness_npm", normal(p.distribution.stiffness_npm)},
            {"tyre_stiffness_npm", normal(p.distribution.tyre_stiffness_npm)},
            {"lateral_m", normal(p.distribution.lateral_m)},
            {"sprung_mass_kg", normal(p.distribution.sprung_mass_kg)},
            {"speed_mps", normal(p.distribution.speed_mps)}}},
          {"truth", truth}};
}

// "K 500000, sigma_k 50000, ..." for a report's header.
inline std::string truth_line(const FleetPreset& p) {
  std::string s;
  const fleet::HyperVector t = p.truth();
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s%s %g", h ? ", " : "", std::string(fleet::kHyperNames[h]).c_str(),
                  t[static_cast<std::size_t>(h)]);
    s += buf;
  }
  return s;
}

}  // namespace ssrfleet::bench
