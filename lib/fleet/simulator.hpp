// Simulates a WIM log: runs each truck over the site with the quarter-car integrator and adds
// independent N(0, sigma_IF^2) measurement noise to every impact factor (paper eq. (6)).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "model/model_extension.hpp"
#include "records/truck.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

struct SimulatedLog {
  std::vector<records::WimRecord> records;   // what the WIM system would log
  std::vector<records::Truck> trucks;            // as they drove (after a fleet-model effect's edits)
  Eigen::ArrayXXd model_if;             // noise-free model IF, sensors x trucks
  Eigen::ArrayXd min_if;                // per truck, minimum IF over the pass
  int lift_offs = 0;                    // trucks whose tyre force went negative somewhere
};

// noise_sd = 0 gives the exact model output. The noise stream is derived from `seed` and is
// independent of the stream that draws a fleet from the same seed.
SimulatedLog simulate_log(const site::Site& site, const std::vector<records::Truck>& trucks, double noise_sd,
                          std::uint64_t seed);

// The same with a model extension switched on at parameters psi (model_extension.hpp): data in
// which the effect is present. A truck's speed is the one the WIM system logs (with speed_bias
// the car really drove at another). min_if leaves out an added profile's own effect. An effect on
// the fleet model (edits_stiffness_distribution) edits each truck before it drives.
SimulatedLog simulate_log(const site::Site& site, const std::vector<records::Truck>& trucks, double noise_sd,
                          std::uint64_t seed, const ModelExtension& extension, const std::vector<double>& psi);

site::TruckBatch to_batch(const std::vector<records::Truck>& trucks);

}  // namespace ssrfleet::fleet
