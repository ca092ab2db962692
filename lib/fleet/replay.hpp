// The one offline driver: feeds a log's records to an OnlineFit, one stage each, then runs the
// schedule's final sweeps (MoveSchedule::final_sweeps), so every command that fits a whole log
// (fit, reproduce, diagnose) gets a posterior of the same quality. A stream (wim_stream.hpp) feeds
// the same OnlineFit record by record with its checkpoints and runs no final sweeps: an online
// posterior is the cloud the stages leave.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "fleet/online_fit.hpp"
#include "records/wim_record.hpp"
#include "smc/engine.hpp"

namespace ssrfleet::fleet {

struct ReplayOptions {
  // -1: the fit's schedule (sampler().options().schedule.final_sweeps); 0: none.
  int final_sweeps = -1;
  // After each record's stage (progress lines, per-record figures). May be empty.
  std::function<void(std::size_t index, const smc::StageSummary& stage, const OnlineFit& fit)> after_record;
  // Before the final sweeps (they take a while on a long log), with their count. May be empty.
  std::function<void(int sweeps)> before_final_sweeps;
};

struct ReplaySummary {
  double replay_s = 0.0;  // wall time of the stages
  int final_sweeps = 0;
  double final_s = 0.0;   // wall time of the final sweeps
};

// Starts after the trucks the fit already holds (a fit restored from a checkpoint: its trucks must be
// the records' first ones). UsageError if final_sweeps < -1 or the fit holds more trucks than records.
ReplaySummary replay(OnlineFit& fit, const std::vector<records::WimRecord>& records, const ReplayOptions& options);

}  // namespace ssrfleet::fleet
