#include "smc/move_schedule.hpp"

#include <cmath>
#include <sstream>

namespace ssrfleet::smc {

std::string to_string(MoveKind kind) {
  switch (kind) {
    case MoveKind::kIndependence: return "independence";
    case MoveKind::kRandomWalk: return "random walk";
    case MoveKind::kModel: return "model";
  }
  return "?";
}

MoveSchedule MoveSchedule::ibis_independence(int max_sweeps, int final_sweeps) {
  MoveSchedule s;
  s.trigger = Trigger::kAfterResampling;
  ScheduledMove independence;
  independence.kind = MoveKind::kIndependence;
  ScheduledMove fallback;
  fallback.kind = MoveKind::kRandomWalk;
  // Below 0.3 the t proposal is too far from the cloud's target (the first few records, a
  // multimodal cloud) for its acceptances alone to meet the jump target.
  fallback.run_if_previous_acceptance_below = 0.3;
  s.sweep = {independence, fallback};
  s.max_sweeps = max_sweeps;
  s.final_sweeps = final_sweeps;
  return s;
}

#define SCHEDULE_RULE(condition, text)                          \
  do {                                                          \
    if (!(condition)) {                                         \
      if (error) *error = std::string("MoveSchedule: ") + text; \
      return false;                                             \
    }                                                           \
  } while (false)

bool MoveSchedule::IsValid(std::string* error) const {
  SCHEDULE_RULE(!sweep.empty(), "sweep must list at least one move");
  SCHEDULE_RULE(min_sweeps >= 1, "min_sweeps must be >= 1");
  SCHEDULE_RULE(max_sweeps >= min_sweeps, "max_sweeps must be >= min_sweeps");
  SCHEDULE_RULE(jump_target > 0.0 && jump_target <= 1.0, "jump_target must be in (0, 1]");
  SCHEDULE_RULE(final_sweeps >= 0, "final_sweeps must be >= 0");
  for (std::size_t m = 0; m < sweep.size(); ++m) {
    const ScheduledMove& s = sweep[m];
    const std::string which = "sweep[" + std::to_string(m) + "] (" + to_string(s.kind) + "): ";
    SCHEDULE_RULE(s.kind != MoveKind::kModel || !s.model_move.empty(), which + "a model move needs its name");
    SCHEDULE_RULE(s.kind == MoveKind::kModel || s.model_move.empty(), which + "only a model move has a name");
    SCHEDULE_RULE(s.run_if_previous_acceptance_below > 0.0 && !std::isnan(s.run_if_previous_acceptance_below),
                  which + "run_if_previous_acceptance_below must be positive");
    SCHEDULE_RULE(s.max_runs_per_stage >= -1, which + "max_runs_per_stage must be >= -1");
  }
  if (error) error->clear();
  return true;
}

#undef SCHEDULE_RULE

std::string MoveSchedule::describe() const {
  std::ostringstream os;
  os << "after a reweight: "
     << (trigger == Trigger::kEveryStep ? "sweeps after every tempering step"
                                        : "sweeps only after a step that resampled (ESS below ess_rmin)")
     << "\n";
  os << "a sweep:";
  for (const ScheduledMove& s : sweep) {
    os << "\n  - " << (s.kind == MoveKind::kModel ? "model move '" + s.model_move + "'" : to_string(s.kind) + " on every block");
    if (s.run_if_previous_acceptance_below <= 1.0)
      os << ", only if the block's previous move accepted below " << s.run_if_previous_acceptance_below;
    if (s.only_at_phi_one) os << ", only at phi = 1";
    if (s.max_runs_per_stage >= 0) os << ", at most " << s.max_runs_per_stage << " per stage";
  }
  os << "\nsweeps: " << min_sweeps << " to " << max_sweeps << ", until every block has jumped " << jump_target
     << "\nafter the last record: " << final_sweeps << " sweeps at phi = 1\n";
  return os.str();
}

}  // namespace ssrfleet::smc
