// Online fleet inference: absorbs WIM records one at a time, each as one tempered SMC stage
// (docs/inference.md), and can hand out the current posterior at any moment.
#pragma once

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "fleet/fleet_target.hpp"
#include "fleet/posterior_cloud.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"
#include "smc/engine.hpp"
#include "util/binary_io.hpp"

namespace ssrfleet::fleet {

class FleetSmc {
 public:
  struct Options {
    // Its `particles` is the particle count P. Its schedule's trigger (every tempering step), sweep
    // count and final_sweeps are used as given; its sweep is the one move_schedule() builds from
    // the counts below. The sweeps per tempering step are capped at 5: the new truck's lateral
    // position is multimodal, so the cloud-scaled jump target is seldom reached by local moves
    // and the cap decides the cost; the particle population, not the chain, carries the modes.
    // final_sweeps = 50: the sweeps of rejuvenate() that an offline replay (`fit`) runs after its
    // last truck; an online stream keeps the cloud the stages leave (see rejuvenate()).
    smc::TemperedSampler::Options sampler = [] {
      smc::TemperedSampler::Options o;
      o.schedule.max_sweeps = 5;
      o.schedule.final_sweeps = 50;
      return o;
    }();
    // Runs per stage of the model move "older trucks" (FleetTarget), at φ = 1. Two keep σ_k and
    // σ_kt within a quarter posterior sd of a long MCMC on the paper's case; one left them 0.4 sd low.
    int older_sweeps = 2;
    PriorBounds prior;
    // FleetTarget::Options::extension: an effect fitted alongside θ (not owned; outlives this).
    const ModelExtension* extension = nullptr;
    // FleetTarget::Options::proposals: a new truck's latents from its table (new_truck_proposals.hpp;
    // not owned). With them the moves run only after a step that resampled (IBIS), not after every
    // tempering step: the stage's weights are then close to the truck's marginal likelihood.
    const NewTruckProposals* proposals = nullptr;
    int proposal_draws = 16;             // FleetTarget::Options::proposal_draws
    int every_stage_moves_until = 25;    // FleetTarget::Options::every_stage_moves_until
    // Runs per stage of "extension random walk", at φ = 1. Three, not two: on a 10 mm bump
    // (diagnose_test) two left the cloud lagging along the length-height ridge, the bump too long
    // and too low, its 95 % interval missing the truth.
    int extension_sweeps = 3;
    // Runs per stage of "extension jump" (an extension with a jump), at φ = 1. The random walk,
    // scaled on the cloud, cannot reach a mode the cloud lost while early trucks favoured another;
    // with the jump, a particle that reaches it is then favoured by the reweighting of each later truck.
    int extension_jump_sweeps = 1;
    // Runs per stage of "tyre stiffness interweave", at φ = 1 (exact regime only). One: speed_bias
    // left a seed with 10 % of its weight in the small-σ_kt funnel without it.
    int interweave_sweeps = 1;
  };

  // The latent core's sweep, in order: a random walk on the newest truck's latents (the engine's
  // block); "older trucks" (φ = 1, older_sweeps per stage); with an extension that moves the
  // forward model, "extension jump" (φ = 1, extension_jump_sweeps per stage, if it has a jump) and
  // "extension random walk" (φ = 1, extension_sweeps per stage); "tyre stiffness interweave"
  // (φ = 1, interweave_sweeps per stage); with an extension that replaces the stiffness
  // distribution, "stiffness distribution"; then "theta". The rest of options.sampler's schedule
  // (trigger, sweep counts, final_sweeps) is kept.
  static smc::MoveSchedule move_schedule(const Options& options);

  // UsageError on invalid options (the sampler's IsValid message).
  FleetSmc(const site::Site& site, Options options);

  // Extends every particle with the record's truck and tempers its likelihood in. Throws
  // NumericalError naming the truck (and the step) if the weights degenerate or a density is NaN.
  const smc::StageSummary& absorb(const records::WimRecord& record);

  // MCMC sweeps at φ = 1 over every truck's latents and θ (FleetTarget::rejuvenate), for the end
  // of an offline replay: the posterior is unchanged, the seed-to-seed error of its summaries
  // smaller. Its random numbers come from the stage count, so call it once, after the last truck.
  // On the paper's 100-truck case (1024 particles, 8 seeds of `fit --final-sweeps N` on one log)
  // the smallest equivalent ESS (seed_scatter.hpp) was 27 (σ_k) without them, 132 after 20 sweeps
  // and 409 after 50 (5.1 M passes, a third of the replay's 16.3 M; 5-6 s); the posterior mean of σ_kt
  // also rose from 171.6k to 177.3k, towards a long MCMC's 180.5k, so the stages alone leave it low.
  void rejuvenate(int sweeps);

  long trucks_seen() const { return static_cast<long>(target_.trucks()); }
  const FleetTarget& target() const { return target_; }
  const smc::TemperedSampler& sampler() const { return sampler_; }
  PosteriorCloud cloud() const;
  // Ids of the trucks absorbed, in order.
  const std::deque<std::string>& truck_ids() const { return truck_ids_; }

  // Checkpoint of everything the next truck depends on (sampler state, particles, data), so a
  // run restored from it continues bit-identically. restore() expects an object built with the
  // same site and options; a checkpoint of another site or particle count is a DataError.
  void save(BinaryWriter& out) const;
  void restore(BinaryReader& in);

 private:
  const site::Site& site_;
  FleetTarget target_;
  smc::TemperedSampler sampler_;
  smc::ParallelFor parallel_;  // for the model's own work between stages (same threads as the engine)
  std::deque<std::string> truck_ids_;
};

}  // namespace ssrfleet::fleet
