#include "fleet/fleet_smc.hpp"

#include "fleet/checkpoint_header.hpp"
#include "fleet/smc_cloud.hpp"

#include <algorithm>
#include <tuple>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
FleetTarget::Options target_options(const FleetSmc::Options& o) {
  FleetTarget::Options t;
  t.particles = o.sampler.particles;
  t.prior = o.prior;
  t.extension = o.extension;
  t.proposals = o.proposals;
  t.proposal_draws = o.proposal_draws;
  t.every_stage_moves_until = o.every_stage_moves_until;
  return t;
}

// Stream keys of the model's own draws, below sampler.model_rngs() of each stage.
constexpr std::uint64_t kInitialDraws = 0;
constexpr std::uint64_t kNewTruckDraws = 1;
constexpr std::uint64_t kRejuvenationDraws = 2;

smc::TemperedSampler::Options with_schedule(const FleetSmc::Options& o) {
  smc::TemperedSampler::Options s = o.sampler;
  s.schedule = FleetSmc::move_schedule(o);
  if (o.proposals != nullptr) {
    // IBIS: moves only once resampling has duplicated particles. The stage has no random-walk
    // block then (FleetTarget::blocks), so no jump target ends the sweeps: run as many as the
    // per-stage counts of the model moves ask for.
    s.schedule.trigger = smc::MoveSchedule::Trigger::kAfterResampling;
    s.schedule.min_sweeps = std::min(s.schedule.max_sweeps, std::max({s.schedule.min_sweeps, o.older_sweeps,
                                                                        o.extension_sweeps, o.extension_jump_sweeps}));
  }
  return s;
}
}  // namespace

smc::MoveSchedule FleetSmc::move_schedule(const Options& o) {
  if (o.older_sweeps < 0) throw UsageError("fleet SMC: older_sweeps must be >= 0");
  if (o.extension_sweeps < 0) throw UsageError("fleet SMC: extension_sweeps must be >= 0");
  if (o.extension_jump_sweeps < 0) throw UsageError("fleet SMC: extension_jump_sweeps must be >= 0");
  if (o.interweave_sweeps < 0) throw UsageError("fleet SMC: interweave_sweeps must be >= 0");
  auto model_move = [](std::string_view name, bool at_phi_one, int per_stage) {
    smc::ScheduledMove m;
    m.kind = smc::MoveKind::kModel;
    m.model_move = std::string(name);
    m.only_at_phi_one = at_phi_one;
    m.max_runs_per_stage = per_stage;
    return m;
  };
  smc::MoveSchedule s = o.sampler.schedule;
  s.sweep = {smc::ScheduledMove{}};  // random walk on the newest truck's latents
  if (o.older_sweeps > 0) s.sweep.push_back(model_move(FleetTarget::kOlderTrucksMove, true, o.older_sweeps));
  const ModelExtension* e = o.extension;
  if (e != nullptr && e->edits_forward()) {
    if (e->jump_draws() > 0 && o.extension_jump_sweeps > 0)
      s.sweep.push_back(model_move(FleetTarget::kExtensionJumpMove, true, o.extension_jump_sweeps));
    if (o.extension_sweeps > 0) s.sweep.push_back(model_move(FleetTarget::kExtensionWalkMove, true, o.extension_sweeps));
  }
  if (o.interweave_sweeps > 0) s.sweep.push_back(model_move(FleetTarget::kInterweaveMove, true, o.interweave_sweeps));
  if (e != nullptr && e->edits_stiffness_distribution())
    s.sweep.push_back(model_move(FleetTarget::kStiffnessMove, false, -1));
  s.sweep.push_back(model_move(FleetTarget::kThetaMove, false, -1));
  return s;
}

FleetSmc::FleetSmc(const site::Site& site, Options options)
    : site_(site), target_(site, target_options(options)), sampler_(with_schedule(options)),
      parallel_(options.sampler.threads) {
  target_.initialise(sampler_.model_rngs().child(kInitialDraws));
}

const smc::StageSummary& FleetSmc::absorb(const records::WimRecord& record) {
  target_.add_truck(record, sampler_.model_rngs().child(kNewTruckDraws), parallel_);
  truck_ids_.push_back(record.truck_id);
  sampler_.run_stage(target_, "truck '" + record.truck_id + "' (#" + std::to_string(target_.trucks()) + ")");
  return sampler_.history().back();
}

void FleetSmc::rejuvenate(int sweeps) {
  target_.rejuvenate(sweeps, sampler_.model_rngs().child(kRejuvenationDraws), parallel_);
}

namespace {
// checkpoint_header.hpp. 1: the latent core before the tyre-stiffness interweave; 2 and 4: the
// marginal core (marginal_smc.cpp); 3: the latent core with the interweave's adapted scale.
constexpr std::uint32_t kCheckpointVersion = 3;
}  // namespace

void FleetSmc::save(BinaryWriter& out) const {
  write_checkpoint_header(out, kCheckpointVersion, site_, sampler_.options().seed);
  const auto state = sampler_.state();
  out.value<std::int32_t>(state.stages_run);
  out.value(state.log_evidence);
  out.matrix(state.log_weights.matrix());
  out.value<std::uint64_t>(truck_ids_.size());
  for (const auto& id : truck_ids_) out.text(id);
  target_.save(out);
}

void FleetSmc::restore(BinaryReader& in) {
  read_checkpoint_header(in, kCheckpointVersion, site_, sampler_.options().seed, [](std::uint32_t v) -> std::string {
    if (v == 1) {
      return "checkpoint format version 1 was written by an older latent core (before the tyre-stiffness "
             "interweave); this build's latent core reads version 3: replay the log into a new state directory";
    }
    if (v == 2 || v == 4) {
      return "checkpoint format version " + std::to_string(v) +
             " is the marginal core's, not the latent core's (3): resume it with the model it was written with";
    }
    return "unsupported checkpoint format version " + std::to_string(v);
  });
  smc::TemperedSampler::State state;
  state.stages_run = in.value<std::int32_t>("stages_run");
  state.log_evidence = in.value<double>("log_evidence");
  state.log_weights = read_log_weights(in, sampler_.options().particles);
  const auto n = in.value<std::uint64_t>("truck_ids");
  if (n > 100'000'000) in.fail("truck_ids", "implausible truck count");
  truck_ids_.clear();
  for (std::uint64_t j = 0; j < n; ++j) truck_ids_.push_back(in.text("truck_id"));
  target_.load(in);
  if (state.stages_run != static_cast<int>(target_.trucks()) || n > static_cast<std::uint64_t>(target_.trucks())) {
    in.fail("trucks", "truck count and stage count disagree");
  }
  sampler_.restore(state);
}

PosteriorCloud FleetSmc::cloud() const {
  auto [speeds, masses] = target_.observed_speeds_and_masses();
  PosteriorCloud c = smc_cloud(site_, sampler_, target_.theta(), std::move(speeds), std::move(masses), trucks_seen());
  if (const ModelExtension* e = target_.extension(); e != nullptr) {
    c.model = e->name();
    for (const auto& p : e->parameters()) c.psi_names.push_back(p.name);
    c.psi = target_.psi();
  }
  return c;
}

}  // namespace ssrfleet::fleet
