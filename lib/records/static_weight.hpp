// One truck's static wheel load as `ssrfleet weigh` estimates it: plain data, no
// format. weigh/ computes it; io/static_weights_csv writes it.
#pragma once

#include <string>

namespace ssrfleet::records {

struct StaticWeight {
  std::string truck_id;
  double static_kn = 0.0;                   // estimated static wheel load (kN)
  double static_kn_q025 = 0.0, static_kn_q975 = 0.0;  // its 95 % interval
  double plain_mean_kn = 0.0;               // the plain mean of the sensors, for comparison
  int iterations = 0;                       // fixed-point iterations used
};

}  // namespace ssrfleet::records
