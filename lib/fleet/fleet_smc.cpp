#include "fleet/fleet_smc.hpp"

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
FleetTarget::Options target_options(const FleetSmc::Options& o) {
  FleetTarget::Options t;
  t.particles = o.sampler.particles;
  t.prior = o.prior;
  t.older_sweeps = o.older_sweeps;
  return t;
}

// Stream keys of the model's own draws, below sampler.model_rngs() of each stage.
constexpr std::uint64_t kInitialDraws = 0;
constexpr std::uint64_t kNewTruckDraws = 1;
}  // namespace

FleetSmc::FleetSmc(const site::Site& site, Options options)
    : site_(site), target_(site, target_options(options)), sampler_(options.sampler),
      parallel_(options.sampler.threads) {
  target_.initialise(sampler_.model_rngs().child(kInitialDraws));
}

const smc::StageSummary& FleetSmc::absorb(const io::WimRecord& record) {
  target_.add_truck(record, sampler_.model_rngs().child(kNewTruckDraws), parallel_);
  speed_mps_.push_back(record.speed_mps);
  sprung_mass_kg_.push_back(record.sprung_mass_kg);
  sampler_.run_stage(target_, "truck '" + record.truck_id + "' (#" + std::to_string(target_.trucks()) + ")");
  return sampler_.history().back();
}

PosteriorCloud FleetSmc::cloud() const {
  PosteriorCloud c;
  c.method = "smc";
  c.theta = target_.theta();
  c.weights = sampler_.weights();
  c.speed_mps = speed_mps_;
  c.sprung_mass_kg = sprung_mass_kg_;
  c.site_fingerprint = site_.fingerprint();
  c.road_name = site_.surface().name;
  c.sensors = site_.sensors();
  c.lateral_min_m = site_.lateral_min_m();
  c.lateral_max_m = site_.lateral_max_m();
  c.trucks_seen = trucks_seen();
  c.ess = sampler_.ess();
  c.log_evidence = sampler_.log_evidence();
  return c;
}

}  // namespace ssrfleet::fleet
