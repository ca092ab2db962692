// The damage a fleet does along the road, as `ssrfleet damage` reports it: plain
// data, no format, no model. damage/ computes it; io/damage_csv writes it.
//
// Per position x, over the fleet's trucks (P the quarter car's tyre force, P_s its static value,
// IF = P / P_s): the damage amplification a_n = E[(P / P_s)^n] = E[IF^n] (Cebon's weighted
// aggregate force A_n = Σ P^n normalised by the same power of the static load), the dynamic
// load coefficient DLC = sd(P) / P_s = sd(IF), and the expected damage per million trucks in
// equivalent standard axles. Each comes as its posterior mean and 95 % limits over θ.
#pragma once

#include <vector>

namespace ssrfleet::records {

// a_n at every position: posterior mean and the 2.5 / 97.5 % quantiles over θ draws.
struct PowerAmplification {
  double power = 1.0;  // n
  std::vector<double> mean, q025, q975;
};

struct DamageProfile {
  std::vector<double> position_m;
  std::vector<double> dlc;                 // posterior mean of sd(IF) over the fleet
  std::vector<PowerAmplification> powers;  // n = 1, n = 4, then the further powers asked for
  double hot_spot_threshold = 1.1;         // on a_4, as a multiple of the static value
  std::vector<bool> hot_spot;              // 95th percentile of a_4 over θ above the threshold
  // Expected damage per million trucks (ESAL: axle load 2 P, standard axle 80 kN, fourth power),
  // dynamic at each position, and static (the same trucks standing still: no position).
  std::vector<double> esal_per_million, esal_per_million_q025, esal_per_million_q975;
  double static_esal_per_million = 0.0;
  long lift_off_passes = 0;                // simulated passes with P < 0 at some position (counted as P = 0)
  long simulated_passes = 0;
};

}  // namespace ssrfleet::records
