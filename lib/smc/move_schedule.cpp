#include "smc/move_schedule.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "util/option_rules.hpp"

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

bool MoveSchedule::IsValid(std::string* error) const {
  util::OptionRules rules("MoveSchedule", error);
  rules.require(!sweep.empty(), "sweep must list at least one move");
  rules.require(min_sweeps >= 1, "min_sweeps", min_sweeps, ">= 1");
  rules.require(max_sweeps >= min_sweeps, "max_sweeps", max_sweeps, ">= min_sweeps (" + std::to_string(min_sweeps) + ")");
  rules.require(jump_target > 0.0 && jump_target <= 1.0, "jump_target", jump_target, "in (0, 1]");
  rules.require(final_sweeps >= 0, "final_sweeps", final_sweeps, ">= 0");
  for (std::size_t m = 0; m < sweep.size(); ++m) {
    const ScheduledMove& s = sweep[m];
    const std::string which = "sweep[" + std::to_string(m) + "] (" + to_string(s.kind) + ")";
    rules.require(s.kind != MoveKind::kModel || !s.model_move.empty(), which + ": a model move needs its name");
    rules.require(s.kind == MoveKind::kModel || s.model_move.empty(), which + ": only a model move has a name");
    rules.require(s.run_if_previous_acceptance_below > 0.0 && !std::isnan(s.run_if_previous_acceptance_below),
                  which + ".run_if_previous_acceptance_below", s.run_if_previous_acceptance_below, "positive");
    rules.require(s.max_runs_per_stage >= -1, which + ".max_runs_per_stage", s.max_runs_per_stage, ">= -1");
  }
  return rules.passed();
}

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
