#include "fleet/simulator.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_01.hpp>

#include "model/extended_forward.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

site::TruckBatch to_batch(const std::vector<records::Truck>& trucks) {
  site::TruckBatch b;
  b.resize(static_cast<Eigen::Index>(trucks.size()));
  for (std::size_t i = 0; i < trucks.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    b.speed_mps[j] = trucks[i].speed_mps;
    b.sprung_mass_kg[j] = trucks[i].sprung_mass_kg;
    b.stiffness_npm[j] = trucks[i].stiffness_npm;
    b.tyre_stiffness_npm[j] = trucks[i].tyre_stiffness_npm;
    b.lateral_m[j] = trucks[i].lateral_m;
  }
  return b;
}

namespace {
void check_trucks(const site::Site& site, const std::vector<records::Truck>& trucks, double noise_sd) {
  if (!(std::isfinite(noise_sd) && noise_sd >= 0.0)) {
    throw UsageError("simulate: noise sd is " + std::to_string(noise_sd) + ", but must be non-negative");
  }
  for (const auto& t : trucks) {
    if (t.lateral_m < site.lateral_min_m() || t.lateral_m > site.lateral_max_m()) {
      throw UsageError("simulate: truck '" + t.truck_id + "' has lateral position " + std::to_string(t.lateral_m) +
                       " m, outside the road surface [" + std::to_string(site.lateral_min_m()) + ", " +
                       std::to_string(site.lateral_max_m()) + "] m");
    }
  }
}

// Records from the model output plus noise; the noise has a stream of its own, so adding it
// never changes which fleet a seed draws.
void add_records(SimulatedLog& log, const std::vector<records::Truck>& trucks, double noise_sd, std::uint64_t seed) {
  log.trucks = trucks;
  log.lift_offs = static_cast<int>((log.min_if < 0.0).count());
  boost::random::mt19937_64 engine(seed ^ 0x6e6f697365ULL /* "noise" */);
  boost::random::normal_distribution<double> noise(0.0, 1.0);
  log.records.reserve(trucks.size());
  for (std::size_t t = 0; t < trucks.size(); ++t) {
    const auto i = static_cast<Eigen::Index>(t);
    records::WimRecord r;
    r.truck_id = trucks[t].truck_id;
    r.vehicle_class = trucks[t].vehicle_class;
    r.speed_mps = trucks[t].speed_mps;
    r.sprung_mass_kg = trucks[t].sprung_mass_kg;
    r.impact_factor = log.model_if.col(i).matrix();
    if (noise_sd > 0.0) {
      for (Eigen::Index m = 0; m < r.impact_factor.size(); ++m) r.impact_factor[m] += noise_sd * noise(engine);
    }
    log.records.push_back(std::move(r));
  }
}
}  // namespace

SimulatedLog simulate_log(const site::Site& site, const std::vector<records::Truck>& trucks, double noise_sd,
                          std::uint64_t seed) {
  check_trucks(site, trucks, noise_sd);
  SimulatedLog log;
  log.model_if.resize(site.sensors(), static_cast<Eigen::Index>(trucks.size()));
  site.impact_factors(to_batch(trucks), log.model_if, &log.min_if);
  add_records(log, trucks, noise_sd, seed);
  return log;
}

SimulatedLog simulate_log(const site::Site& site, const std::vector<records::Truck>& trucks, double noise_sd,
                          std::uint64_t seed, const ModelExtension& extension, const std::vector<double>& psi) {
  check_trucks(site, trucks, noise_sd);
  if (static_cast<Eigen::Index>(psi.size()) != extension.dim() || !extension.in_prior(psi.data())) {
    throw UsageError("simulate: parameters of effect '" + extension.name() + "' are missing or outside their range");
  }
  // A fleet-model effect edits the trucks first, each with draws of its own from a stream of the
  // seed's (neither the fleet's nor the noise's, so a seed draws the same base fleet and noise).
  std::vector<records::Truck> edited = trucks;
  if (extension.edits_stiffness_distribution()) {
    boost::random::mt19937_64 engine(seed ^ 0x636c6173736573ULL /* "classes" */);
    boost::random::uniform_01<double> uniform;
    boost::random::normal_distribution<double> normal(0.0, 1.0);
    for (auto& t : edited) {
      const double u = uniform(engine);
      extension.edit_simulated_truck(psi.data(), t, u, normal(engine));
    }
  }
  std::vector<ExtendedPass> passes;
  passes.reserve(edited.size());
  for (const auto& t : edited) {
    passes.push_back({base_pass(site, t.speed_mps, t.sprung_mass_kg, t.stiffness_npm, t.tyre_stiffness_npm, t.lateral_m),
                      psi.data()});
  }
  SimulatedLog log;
  log.model_if.resize(site.sensors(), static_cast<Eigen::Index>(trucks.size()));
  simulate_passes(site, &extension, passes, log.model_if, &log.min_if);
  add_records(log, edited, noise_sd, seed);
  return log;
}

}  // namespace ssrfleet::fleet
