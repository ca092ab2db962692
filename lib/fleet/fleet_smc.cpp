#include "fleet/fleet_smc.hpp"

#include "fleet/checkpoint_header.hpp"
#include "fleet/smc_cloud.hpp"

#include <tuple>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
FleetTarget::Options target_options(const FleetSmc::Options& o) {
  FleetTarget::Options t;
  t.particles = o.sampler.particles;
  t.prior = o.prior;
  t.older_sweeps = o.older_sweeps;
  t.window = o.window;
  t.extension = o.extension;
  t.extension_sweeps = o.extension_sweeps;
  t.extension_jump_sweeps = o.extension_jump_sweeps;
  return t;
}

// Stream keys of the model's own draws, below sampler.model_rngs() of each stage.
constexpr std::uint64_t kInitialDraws = 0;
constexpr std::uint64_t kNewTruckDraws = 1;
constexpr std::uint64_t kRejuvenationDraws = 2;
}  // namespace

FleetSmc::FleetSmc(const site::Site& site, Options options)
    : site_(site), target_(site, target_options(options)), sampler_(options.sampler), window_(options.window),
      parallel_(options.sampler.threads) {
  target_.initialise(sampler_.model_rngs().child(kInitialDraws));
}

const smc::StageSummary& FleetSmc::absorb(const records::WimRecord& record) {
  target_.add_truck(record, sampler_.model_rngs().child(kNewTruckDraws), parallel_);
  truck_ids_.push_back(record.truck_id);
  if (window_ > 0 && truck_ids_.size() > FleetTarget::kPredictionPool) truck_ids_.pop_front();
  sampler_.run_stage(target_, "truck '" + record.truck_id + "' (#" + std::to_string(target_.trucks()) + ")");
  return sampler_.history().back();
}

void FleetSmc::rejuvenate(int sweeps) {
  target_.rejuvenate(sweeps, sampler_.model_rngs().child(kRejuvenationDraws), parallel_);
}

namespace {
constexpr std::uint32_t kCheckpointVersion = 1;  // checkpoint_header.hpp
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
  read_checkpoint_header(in, kCheckpointVersion, site_, sampler_.options().seed, [](std::uint32_t v) {
    return "checkpoint format version " + std::to_string(v) + " is not the latent core's (1): resume it without --window";
  });
  smc::TemperedSampler::State state;
  state.stages_run = in.value<std::int32_t>("stages_run");
  state.log_evidence = in.value<double>("log_evidence");
  state.log_weights = in.matrix("log_weights", sampler_.options().particles, 1).array();
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
  return smc_cloud(site_, sampler_, target_.theta(), std::move(speeds), std::move(masses), trucks_seen());
}

}  // namespace ssrfleet::fleet
