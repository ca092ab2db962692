// The paper's theoretical test (Wilson, Harris & O'Brien §4) end to end: the Table 1 fleet on
// AS1, streamed truck by truck through the SMC, then the data behind Figs. 4 and 6-9, the
// posterior's evolution after every truck, and a summary.md with each measured value beside the
// paper's statement. Every measured number comes from this run; the paper's column is text.
#pragma once

#include <array>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"

namespace ssrfleet::reproduce {

struct Options {
  std::string out_dir = "reproduce";
  std::uint64_t seed = 1;
  int trucks = 100;
  int particles = 1024;
  int threads = 0;          // 0 = all cores
  double noise_sd = 0.02;   // σ_IF of the simulated observations
  int theta_draws = 200;    // prediction: θ draws ...
  int trucks_per_draw = 100;  // ... and simulated trucks per draw
  bool plots = true;        // run gnuplot when it is on PATH (scripts are written regardless)
  // The model the fits use (model/model_spec.hpp; "base" = the paper's), and effects hidden in the
  // simulated data (every parameter given; "" = none, the paper's data). Together they test
  // whether a model recovers an effect and the SSR prediction with it.
  std::string model = "base";
  std::string effect;
  std::ostream* progress = nullptr;  // progress lines; nullptr = quiet

  void validate() const;  // UsageError naming the option
};

struct SiteComparison {     // Fig. 9: prediction from the AS1 fit vs a new fleet on another road
  std::string road;
  double max_abs_mean_diff = 0.0;   // largest |predicted mean - true mean| over sensors
  int max_mean_sensor = 0;          // 1-based
  double max_abs_population_diff = 0.0;  // largest |predicted mean - Table 1 population mean|
  double max_abs_oracle_diff = 0.0;  // largest |population mean - true mean|: a perfect predictor's miss
  int sensors = 0;
  int band_covers_population = 0;    // sensors whose 95 % band of the mean holds the population mean
  double max_band_half_width = 0.0;  // widest half-width of that band over sensors
  double max_abs_limit_diff = 0.0;  // largest |predicted limit - empirical limit| over sensors, both limits
  double coverage = 0.0;            // share of the new fleet's observed IFs inside the predicted limits
};

struct Result {
  std::array<fleet::ParameterSummary, fleet::kHyperCount> hyper{};  // after the last truck
  std::array<double, fleet::kHyperCount> truth{};                   // Table 1 (and σ_IF)
  int hyper_covered = 0;               // how many 95 % intervals contain the truth
  double observed_if_min = 0.0, observed_if_max = 0.0, observed_dlc = 0.0;
  double fig7_coverage = 0.0;          // share of observed IFs inside the 95 % prediction limits
  double fig8_coverage = 0.0;          // the same at sensors 11-16, from the fit on sensors 1-10
  int fig8_predicted_peak = 0;         // sensor (1-based) of the highest predicted mean among 11-16
  int fig8_observed_peak = 0;          // ... and of the highest observed mean
  std::array<int, 2> fig8_predicted_top2{}, fig8_observed_top2{};  // the two highest means among 11-16, sorted
  double fig8_max_mean_diff = 0.0;  // largest |predicted - observed mean| at 11-16
  std::vector<SiteComparison> fig9;    // AS2, AS3
  std::array<double, 3> k_interval_width{};  // 95 % width of K after 10 %, 50 %, 100 % of the trucks
  double fit_wall_s = 0.0, total_wall_s = 0.0;
  bool plotted = false;                // gnuplot ran
  std::vector<std::string> files;      // written, relative to out_dir
};

// Runs everything and writes the files into options.out_dir (created if missing).
Result run(const Options& options);

}  // namespace ssrfleet::reproduce
