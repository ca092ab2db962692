// The tempered SMC engine (Del Moral, Doucet & Jasra 2006; Chopin 2002 for the data-tempered
// IBIS use). A stage tempers one log-likelihood increment ℓ into the target, φ: 0 → 1:
//   1. choose φ' by bisection so the relative conditional ESS of the step is cess_target;
//   2. reweight, log w_i += (φ' - φ) ℓ_i; the log-evidence increment is log Σ W_i e^{(φ'-φ) ℓ_i};
//   3. resample (ancestors from one stream) if ESS < ess_rmin · P; otherwise carry the weights;
//   4. move every particle by the schedule's sweeps (move_schedule.hpp) at φ', which leave π_φ'
//      invariant, so the weighted cloud stays a valid sample whether or not step 3 resampled.
// Weights carry over from one stage to the next, so a sequence of stages (one per record) is
// IBIS with tempering, and the stage increments sum to log p(y_1:n).
//
// Reproducibility: every random number comes from a counter-based stream keyed by
// (seed, stage, step, purpose, sweep, block, particle), and per-particle work never depends on
// the chunking, so a run is bit-identical for any `threads`.
//
// Usage (one stage; the model already holds its particles: prior draws for static tempering, or
// the previous posterior extended with the new record's latents):
//   smc::TemperedSampler::Options options;  options.particles = model.particles();
//   smc::TemperedSampler sampler(options);            // UsageError if options are invalid
//   smc::StageSummary s = sampler.run_stage(model, "truck 17");
//   double logZ = sampler.log_evidence();  Eigen::ArrayXd W = sampler.weights();
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "smc/mh_kernel.hpp"
#include "smc/move_schedule.hpp"
#include "smc/parallel.hpp"
#include "smc/resampling.hpp"
#include "smc/rng.hpp"
#include "smc/target.hpp"
#include "smc/tempering.hpp"

namespace ssrfleet::smc {

// What one tempering step did (BlackJAX's SMCInfo): a progress line and a test both read it.
struct StepInfo {
  int step = 0;                         // 0-based within the stage
  double phi = 0.0;                     // temperature reached
  double delta_phi = 0.0;               // step taken
  double relative_cess = 1.0;           // conditional ESS / P achieved by the step
  int bisections = 0;
  double log_evidence_increment = 0.0;  // log Σ W_i exp(δ ℓ_i)
  double ess = 0.0;                     // ESS after reweighting, before any resampling
  bool resampled = false;
  MhSummary mh;                         // sweeps, acceptance and jump per block
};

struct StageSummary {
  int stage = 0;  // 0-based index among the stages this sampler has run
  std::string label;
  std::vector<StepInfo> steps;
  double log_evidence_increment = 0.0;  // log p(this increment | everything before)
  double log_evidence = 0.0;            // cumulative over all stages so far
  double final_ess = 0.0;               // ESS at the end of the stage
  double wall_time_s = 0.0;

  int resamplings() const;
  std::string BriefReport() const;  // one line
  std::string FullReport() const;   // one line per step
};

class TemperedSampler {
 public:
  using ProgressCallback = std::function<void(const StageSummary& stage_so_far, const StepInfo& step)>;

  // The most particles a sampler takes: 7 hyperparameters x 1e7 particles is 560 MB before any
  // truck; more is a typing error, refused before anything is allocated (docs/site-data.md).
  static constexpr Eigen::Index kMaxParticles = 10'000'000;

  struct Options {
    Eigen::Index particles = 1000;  // P; must equal model.particles()
    int threads = default_threads();
    std::uint64_t seed = 1;
    // Resample when ESS < ess_rmin · P (particles' ESSrmin); 0 never resamples, 1 always.
    double ess_rmin = 0.5;
    ResamplingScheme resampling = ResamplingScheme::systematic;
    // Which moves run, and when (move_schedule.hpp): the one place to read it.
    MoveSchedule schedule;
    TemperingOptions tempering;  // cess_target (default 0.9) and the bisection
    MhOptions mh;                // how the block moves propose
    ProgressCallback progress;   // called after every step if set; the library prints nothing

    // Checks read as rules; false with a message naming the option and the rule.
    bool IsValid(std::string* error) const;
    static int default_threads();
  };

  explicit TemperedSampler(Options options);

  // Tempers the model's current increment ℓ in, from φ = 0 to 1. Throws NumericalError naming
  // `label` (and the particle) on a NaN log density or a stalled tempering; UsageError if
  // model.particles() != options.particles.
  // A correction stage (counts_as_evidence = false) tempers in a change of the target that is not
  // data, e.g. the ratio between two numerical approximations of one likelihood: it reweights,
  // resamples and moves like any stage, but its increment is not added to log_evidence().
  StageSummary run_stage(TemperedModel& model, std::string_view label, bool counts_as_evidence = true);

  // Exactly `sweeps` sweeps of the schedule at φ = 1 on the current cloud, outside any stage (the
  // schedule's final_sweeps after the last record): leaves the target and the weights unchanged.
  // Random streams are keyed by the stage count and a per-call counter, so call it between stages
  // only. after_sweep (if set) is called after each sweep, with the model holding that sweep's
  // states (waste-free use of a final phase: every sweep's cloud is a draw of the same target).
  // Returns what the sweeps did.
  MhSummary move(TemperedModel& model, std::string_view label, int sweeps, const SweepObserver& after_sweep = {});

  // Streams for the model's own draws before stage `stages_run()` (prior draws, new latents):
  // use model_rngs().stream(i) for particle i. Disjoint from the engine's streams.
  RngFactory model_rngs() const;

  const Options& options() const { return options_; }
  int stages_run() const { return stages_run_; }
  double log_evidence() const { return log_evidence_; }
  const Eigen::ArrayXd& log_weights() const { return log_weights_; }  // normalised: log W_i
  Eigen::ArrayXd weights() const;                                     // W_i, sum 1
  double ess() const;
  // The last kHistoryLimit stages (all of them in an offline replay of up to that many records).
  const std::vector<StageSummary>& history() const { return history_; }
  static constexpr std::size_t kHistoryLimit = 1000;

  // What a checkpoint must keep to continue bit-identically: every random stream is keyed by
  // the stage count, so with the model's particles restored the next stage is the same as in an
  // uninterrupted run. (The per-stage history is a report, not state, and is not restored.)
  struct State {
    int stages_run = 0;
    double log_evidence = 0.0;
    Eigen::ArrayXd log_weights;
    int moves_run = 0;  // calls of move() (their streams are keyed by it)
  };
  State state() const { return {stages_run_, log_evidence_, log_weights_, moves_run_}; }
  // UsageError if the weights do not match options().particles.
  void restore(const State& state);

 private:
  Options options_;
  ParallelFor parallel_;
  RngFactory root_;
  int stages_run_ = 0;
  int moves_run_ = 0;
  double log_evidence_ = 0.0;
  Eigen::ArrayXd log_weights_;
  std::vector<StageSummary> history_;
};

}  // namespace ssrfleet::smc
