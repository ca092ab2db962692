// One row set of a stream's history (io/history_db.hpp): what the posterior said at one
// checkpoint. Plain data, so the stream can fill it and io can store it without knowing each other.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ssrfleet::records {

struct HyperparameterSummaryRow {
  std::string vehicle_class;  // the class's label ("" for a log without a class column)
  std::string name;  // fleet_model.hpp's hyperparameter names, then the extension's parameters
  double mean = 0.0, sd = 0.0, q025 = 0.0, q975 = 0.0;
};

struct PredictionRow {
  double position_m = 0.0;
  double mean_if = 0.0, lower95 = 0.0, upper95 = 0.0;  // one truck's IF: mean and 95 % prediction limits
  double mean_lower95 = 0.0, mean_upper95 = 0.0;       // 95 % band of the fleet-mean IF
};

struct HistoryReport {
  std::uint64_t seq = 0;      // the checkpoint's sequence number: 1 for the state's first, then +1 each
  std::int64_t trucks = 0;    // trucks absorbed into the posterior
  double time_s = 0.0;        // Unix time (s) when the row set was written
  std::string source;         // the input the stream was reading
  std::uint64_t lines_consumed = 0;
  double ess = 0.0;           // the particle cloud's effective sample size (the smallest over classes)
  std::uint64_t checkpoint_checksum = 0;  // the seal of checkpoint.bin number `seq`
  std::vector<HyperparameterSummaryRow> hyperparameters;
  std::vector<PredictionRow> predictions;
};

}  // namespace ssrfleet::records
