// One truck as a WIM site recorded it (docs/site-data.md): plain data, no format. io/wim_log reads
// and writes it; the fleet model and the samplers consume it without knowing where it came from.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Core>

namespace ssrfleet::records {

struct WimRecord {
  std::string truck_id;
  std::optional<double> time_s;
  double speed_mps = 0.0;
  double sprung_mass_kg = 0.0;
  Eigen::VectorXd impact_factor;  // one per sensor, in sensor order
  std::string vehicle_class;      // the log's `class` column (records/vehicle_class.hpp); "" = unlabelled
  std::uint32_t site = 0;         // which of a fit's sites logged it (fleet/joint_sites.hpp); 0 for one site
  std::size_t line = 0;           // where it came from
};

}  // namespace ssrfleet::records
