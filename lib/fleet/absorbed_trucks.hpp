// Every truck a MarginalTarget has absorbed: its record's data and its best fit, in truck order.
// A rebuild of the tables reads them all; nothing else reads old trucks. They live in the
// process's memory or, given a directory, in spill files there (util/spill_vector.hpp), so a
// stream's own memory does not grow with its trucks (about 270 bytes a truck on 16 sensors).
#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "model/truck_table.hpp"
#include "util/spill_vector.hpp"

namespace ssrfleet::fleet {

class AbsorbedTrucks {
 public:
  AbsorbedTrucks() = default;
  // In spill files in `spill_directory` ("": in memory). IoError if a file cannot be made.
  explicit AbsorbedTrucks(const std::string& spill_directory) : heads_(spill_directory), impact_factors_(spill_directory) {}

  // IoError from a full disk: nothing is appended then.
  void push_back(double speed_mps, double sprung_mass_kg, std::uint32_t site, const Eigen::VectorXd& impact_factors,
                 const model::TruckFit& fit) {
    const std::size_t before = impact_factors_.size();
    impact_factors_.append(impact_factors.data(), static_cast<std::size_t>(impact_factors.size()));
    try {
      heads_.push_back({speed_mps, sprung_mass_kg, before, site, static_cast<std::uint32_t>(impact_factors.size()), fit});
    } catch (...) {
      impact_factors_.truncate(before);
      throw;
    }
  }
  void clear() {
    heads_.clear();
    impact_factors_.clear();
  }

  std::size_t size() const { return heads_.size(); }
  bool empty() const { return heads_.empty(); }
  // Truck i's data (references valid until the next push_back).
  double speed_mps(std::size_t i) const { return heads_[i].speed_mps; }
  double sprung_mass_kg(std::size_t i) const { return heads_[i].sprung_mass_kg; }
  std::uint32_t site(std::size_t i) const { return heads_[i].site; }
  Eigen::Map<const Eigen::VectorXd> impact_factors(std::size_t i) const {
    const Head& h = heads_[i];
    return {impact_factors_.data() + h.first_if, static_cast<Eigen::Index>(h.sensors)};
  }
  const model::TruckFit& fit(std::size_t i) const { return heads_[i].fit; }

 private:
  struct Head {
    double speed_mps = 0.0, sprung_mass_kg = 0.0;
    std::uint64_t first_if = 0;  // index of its first impact factor
    std::uint32_t site = 0, sensors = 0;
    model::TruckFit fit;
  };
  util::SpillVector<Head> heads_;
  util::SpillVector<double> impact_factors_;
};

}  // namespace ssrfleet::fleet
