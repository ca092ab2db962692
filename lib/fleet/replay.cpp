#include "fleet/replay.hpp"

#include <chrono>
#include <string>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

ReplaySummary replay(OnlineFit& fit, const std::vector<records::WimRecord>& records, const ReplayOptions& options) {
  if (options.final_sweeps < -1) throw UsageError("replay: final_sweeps must be >= 0 (or -1 for the schedule's)");
  ReplaySummary s;
  const auto started = Clock::now();
  // A fit restored from a checkpoint (fit --checkpoint) goes on after the trucks it holds, which the
  // caller has checked are the records' first ones.
  const auto first = static_cast<std::size_t>(fit.trucks_seen());
  if (first > records.size()) {
    throw UsageError("replay: the fit holds " + std::to_string(first) + " trucks, more than the " +
                     std::to_string(records.size()) + " records");
  }
  for (std::size_t t = first; t < records.size(); ++t) {
    fit.prepare(records, t);
    const smc::StageSummary stage = fit.absorb(records[t]);
    if (options.after_record) options.after_record(t, stage, fit);
  }
  s.replay_s = seconds_since(started);
  s.final_sweeps = options.final_sweeps >= 0 ? options.final_sweeps : fit.sampler().options().schedule.final_sweeps;
  if (s.final_sweeps > 0) {
    if (options.before_final_sweeps) options.before_final_sweeps(s.final_sweeps);
    const auto final_started = Clock::now();
    fit.rejuvenate(s.final_sweeps);
    s.final_s = seconds_since(final_started);
  }
  return s;
}

}  // namespace ssrfleet::fleet
