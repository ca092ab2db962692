// One truck as a WIM site's raw tyre-force sensors logged it (the force_1..force_M form of the WIM
// log, docs/site-data.md) where the sprung mass may be absent: `ssrfleet weigh` estimates the static
// weight from these forces. Plain data, no format: io/force_log reads and writes it.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include <Eigen/Core>

namespace ssrfleet::records {

struct ForceRecord {
  std::string truck_id;
  std::optional<double> time_s;
  double speed_mps = 0.0;
  std::optional<double> sprung_mass_kg;  // what the log says, if anything (weigh does not use it)
  Eigen::VectorXd force_n;               // tyre force at each sensor, in sensor order (N)
  std::size_t line = 0;                  // where it came from
};

}  // namespace ssrfleet::records
