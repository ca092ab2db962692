// Which MCMC moves a TemperedSampler runs, and when: the one place a reader looks.
//
//   after a reweight    `trigger`: a sweep sequence after every tempering step (a target with a
//                       new record's latents to move), or only after a step whose ESS fell below
//                       ess_rmin · P and so resampled (IBIS, Chopin 2002: static parameters need
//                       rejuvenating only once resampling has duplicated particles).
//   a sweep             `sweep`: the moves in order. A block move (independence, random walk)
//                       runs on every MH block of the model in turn; a model move is one the
//                       model implements (Gibbs draws, a model-specific MH), named by the model.
//                       Each entry may be conditional: only at φ = 1, at most so many runs per
//                       stage, or only while the move before it on the same block accepted less
//                       than a threshold (the random-walk fallback of an independence proposal).
//   how many sweeps     until every block has moved `jump_target` (mh_kernel.hpp), between
//                       min_sweeps and max_sweeps.
//   after the last one  `final_sweeps`: exactly that many sweeps at φ = 1, run by a driver that
//                       replays a whole log (fit) once the last record is in.
//
// Every move that runs is recorded in the step's MhSummary (MoveRecord: runs, skips, acceptance),
// so a test can check that each scheduled move ran. No move runs another.
#pragma once

#include <string>
#include <vector>

namespace ssrfleet::smc {

enum class MoveKind {
  kIndependence,  // per block: a t proposal fitted to the weighted cloud (mh_kernel.hpp)
  kRandomWalk,    // per block: a Gaussian random walk scaled on the cloud
  kModel,         // a move the model runs itself (TemperedModel::model_moves)
};

struct ScheduledMove {
  MoveKind kind = MoveKind::kRandomWalk;
  std::string model_move;  // kModel: the model's name for it
  // Block moves: run only when the previous block move of this sweep on the same block accepted
  // fewer than this share of particles (above 1: always).
  double run_if_previous_acceptance_below = 2.0;
  bool only_at_phi_one = false;    // skipped while a stage is still tempering (φ < 1)
  int max_runs_per_stage = -1;     // -1: no limit; counted over all steps of one stage
};

struct MoveSchedule {
  enum class Trigger { kEveryStep, kAfterResampling };
  Trigger trigger = Trigger::kEveryStep;
  std::vector<ScheduledMove> sweep{ScheduledMove{}};  // a random walk on every block
  int min_sweeps = 1;
  int max_sweeps = 20;
  double jump_target = 0.5;  // in (0, 1]: mh_kernel.hpp
  int final_sweeps = 0;      // >= 0

  // The IBIS schedule of a static-parameter target: moves only after resampling; each sweep an
  // independence proposal per block, then a random walk while that accepts below 0.3.
  static MoveSchedule ibis_independence(int max_sweeps, int final_sweeps);

  bool IsValid(std::string* error) const;
  // The schedule in words, one line per part (for --verbose output and the docs).
  std::string describe() const;
};

std::string to_string(MoveKind kind);

}  // namespace ssrfleet::smc
