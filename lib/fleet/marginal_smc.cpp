#include "fleet/marginal_smc.hpp"

#include "fleet/checkpoint_header.hpp"
#include "fleet/joint_sites.hpp"
#include "fleet/smc_cloud.hpp"

#include <algorithm>
#include <sstream>
#include <tuple>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
MarginalTarget::Options with_particles(MarginalTarget::Options t, Eigen::Index particles) {
  t.particles = particles;
  return t;
}
constexpr std::uint64_t kInitialDraws = 0;

// An extension's jump between distant modes of the stiffness distribution (MarginalTarget's model
// move) runs in every sweep, after the block moves.
smc::TemperedSampler::Options with_model_moves(smc::TemperedSampler::Options s, const ModelExtension* extension) {
  if (extension != nullptr && extension->stiffness_jump_draws() > 0) {
    smc::ScheduledMove jump;
    jump.kind = smc::MoveKind::kModel;
    jump.model_move = "stiffness jump";
    s.schedule.sweep.push_back(jump);
  }
  return s;
}

// The extension's name and ψ draws in a cloud (nothing for the base model).
void add_extension(PosteriorCloud& c, const ModelExtension* extension, const Eigen::MatrixXd& psi) {
  if (extension == nullptr) return;
  c.model = extension->name();
  for (const auto& p : extension->parameters()) c.psi_names.push_back(p.name);
  c.psi = psi;
}
}  // namespace

MarginalSmc::MarginalSmc(std::vector<const site::Site*> sites, Options options)
    : sites_(std::move(sites)),
      options_(std::move(options)),
      target_(sites_, with_particles(options_.target, options_.sampler.particles)),
      sampler_(with_model_moves(options_.sampler, options_.target.extension)),
      parallel_(options_.sampler.threads),
      truck_ids_(options_.target.table_spill_directory) {
  fingerprint_ = sites_fingerprint(sites_);
  site_trucks_.assign(sites_.size(), 0);
  recent_.assign(sites_.size(), {});
  target_.initialise(sampler_.model_rngs().child(kInitialDraws));
}

void MarginalSmc::note_site(std::uint32_t site, std::size_t truck) {
  if (sites_.size() == 1) return;  // one site: the pool is the last trucks
  const std::size_t per_site = std::max(kMinSitePool, kPredictionPool / sites_.size());
  ++site_trucks_[site];
  recent_[site].push_back(truck);
  if (recent_[site].size() > per_site) recent_[site].pop_front();
}

smc::StageSummary MarginalSmc::absorb(const records::WimRecord& record) {
  drop_pool();  // the posterior is about to change: the pooled clouds no longer draw from it
  target_.add_truck(record.speed_mps, record.sprung_mass_kg, record.impact_factor, sampler_.weights(), parallel_,
                    record.site);
  truck_ids_.push_back(record.truck_id);
  note_site(record.site, static_cast<std::size_t>(target_.trucks() - 1));
  smc::StageSummary truck = sampler_.run_stage(
      target_, "truck '" + record.truck_id + "' (#" + std::to_string(target_.trucks()) + ")");
  target_.finish_stage();
  last_rebuild_ = target_.rebuild_reason(sampler_.weights());
  if (!last_rebuild_.empty()) {
    target_.begin_rebuild(sampler_.weights(), parallel_);
    sampler_.run_stage(target_, "tables rebuilt: " + last_rebuild_, /*counts_as_evidence=*/false);
    target_.finish_stage();
  }
  return truck;
}

void MarginalSmc::prepare(const std::vector<records::WimRecord>& records, std::size_t next) {
  if (next >= records.size()) return;
  const std::size_t count = std::min(target_.prebuild_span(), records.size() - next);
  if (count < 2) return;  // one truck: absorb() builds it with both threads
  std::vector<MarginalTarget::UpcomingTruck> upcoming;
  upcoming.reserve(count);
  for (std::size_t i = next; i < next + count; ++i)
    upcoming.push_back({records[i].speed_mps, records[i].sprung_mass_kg, &records[i].impact_factor, records[i].site});
  target_.prebuild(upcoming, sampler_.weights(), parallel_);
}

smc::MhSummary MarginalSmc::rejuvenate(int sweeps) {
  if (sweeps < 0) throw UsageError("MarginalSmc::rejuvenate: sweeps must be >= 0");
  drop_pool();
  if (sweeps == 0) return {};
  const Eigen::Index P = options_.sampler.particles;
  // The last `kept` sweeps' clouds (all of them unless that would pass max_pooled_draws).
  const int kept = static_cast<int>(std::clamp<std::int64_t>(options_.max_pooled_draws / P, 1, sweeps));
  Eigen::MatrixXd pool(kHyperCount, P * kept), psi_pool(target_.psi().rows(), P * kept);
  const smc::MhSummary s = sampler_.move(target_, "final rejuvenation", sweeps, [&](int sweep) {
    const int slot = sweep - (sweeps - kept);
    if (slot < 0) return;
    pool.middleCols(slot * P, P) = target_.theta();
    psi_pool.middleCols(slot * P, P) = target_.psi();
  });
  pooled_theta_ = std::move(pool);
  pooled_psi_ = std::move(psi_pool);
  return s;
}

PosteriorCloud MarginalSmc::cloud() const {
  PosteriorCloud c = current_cloud();
  const int sweeps = pooled_sweeps();
  if (sweeps == 0) return c;
  // The pool: the weights do not change in a move, so every sweep's copy of particle i carries W_i.
  c.theta = pooled_theta_;
  if (c.psi.rows() > 0) c.psi = pooled_psi_;
  // (Through a temporary: Eigen would resize the destination before reading a replicate of itself.)
  const Eigen::ArrayXd one_sweep = c.weights;
  c.weights = one_sweep.replicate(sweeps, 1) / static_cast<double>(sweeps);
  c.pooled_sweeps = sweeps;
  return c;
}

PosteriorCloud MarginalSmc::current_cloud() const {
  const AbsorbedTrucks& a = target_.absorbed();
  if (sites_.size() == 1) {
    std::vector<double> speed, mass;
    for (std::size_t i = a.size() > kPredictionPool ? a.size() - kPredictionPool : 0; i < a.size(); ++i) {
      speed.push_back(a.speed_mps(i));
      mass.push_back(a.sprung_mass_kg(i));
    }
    PosteriorCloud c = smc_cloud(*sites_.front(), sampler_, target_.theta(), std::move(speed), std::move(mass), trucks_seen());
    add_extension(c, target_.extension(), target_.psi());
    return c;
  }
  // Each site's most recent trucks (kept as they arrive: a stream asks for the cloud at every
  // checkpoint, so this costs O(pool), not O(n)), site by site.
  std::vector<double> speed, mass;
  std::vector<CloudSite> entries;
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const site::Site& site = *sites_[s];
    entries.push_back({"", site.fingerprint(), site.surface().name, site.sensors(), site.lateral_min_m(),
                       site.lateral_max_m(), site_trucks_[s], speed.size(), recent_[s].size()});
    for (const std::size_t i : recent_[s]) {
      speed.push_back(a.speed_mps(i));
      mass.push_back(a.sprung_mass_kg(i));
    }
  }
  PosteriorCloud c = smc_cloud(*sites_.front(), sampler_, target_.theta(), std::move(speed), std::move(mass), trucks_seen());
  c.site_fingerprint = fingerprint_;
  c.road_name.clear();
  for (std::size_t s = 0; s < sites_.size(); ++s) c.road_name += (s ? "+" : "") + sites_[s]->surface().name;
  c.sites = std::move(entries);
  add_extension(c, target_.extension(), target_.psi());
  return c;
}

namespace {
// Version 1 was the latent-variable core (FleetSmc) of 0.1; version 2 this one without checksums;
// 3 the latent core now; 4 this one with a checksum after each truck record (checkpoint_header.hpp).
constexpr std::uint32_t kCheckpointVersion = 4;
}  // namespace

void MarginalSmc::save(BinaryWriter& out) const {
  save_state(out);
  save_trucks(out, 0, truck_ids_.size());
}

void MarginalSmc::restore(BinaryReader& in) { restore_split(in, in); }

void MarginalSmc::save_state(BinaryWriter& out) const {
  write_checkpoint_header(out, kCheckpointVersion, fingerprint_, sampler_.options().seed);
  const auto state = sampler_.state();
  out.value<std::int32_t>(state.stages_run);
  out.value<std::int32_t>(state.moves_run);
  out.value(state.log_evidence);
  out.matrix(state.log_weights.matrix());
  target_.save_particles(out);
}

void MarginalSmc::save_trucks(BinaryWriter& out, std::size_t begin, std::size_t end) const {
  const util::Ranks& ranks = target_.ranks();
  auto record = [&](BinaryWriter& w, std::size_t i) {
    w.text(std::string(truck_ids_[i]));
    target_.save_trucks(w, i, i + 1);
    w.seal();  // each record checked on its own: the truck log is appended to
  };
  if (ranks.size() == 1) {
    for (std::size_t i = begin; i < end; ++i) record(out, i);
    return;
  }
  // Several ranks: a truck's table is on its own rank, which writes its record (sealed on its own,
  // so the bytes are those one process writes) and sends it to rank 0, which writes them all in
  // truck order. In blocks of trucks, so rank 0 never holds more than a block of the others'
  // tables. Collective; what `out` receives on the other ranks is nothing.
  constexpr std::size_t kBlock = 4096;
  for (std::size_t first = begin; first < end; first += kBlock) {
    const std::size_t last = std::min(end, first + kBlock);
    std::ostringstream mine;
    BinaryWriter blob(mine);
    for (std::size_t i = first; i < last; ++i) {
      if (!ranks.owns(i)) continue;
      std::ostringstream one;
      BinaryWriter w(one);
      record(w, i);
      blob.text(one.str());
    }
    const std::vector<std::string> all = ranks.gather(mine.str(), 0);
    if (ranks.rank() != 0) continue;
    std::vector<std::istringstream> from;
    std::vector<BinaryReader> readers;
    from.reserve(all.size());
    readers.reserve(all.size());
    for (const std::string& s : all) {
      from.emplace_back(s);
      readers.emplace_back(from.back(), "a rank's truck records");
    }
    for (std::size_t i = first; i < last; ++i) {
      out.sealed_bytes(readers[static_cast<std::size_t>(ranks.owner(i))].text("truck record", std::size_t{1} << 30));
    }
  }
}

void MarginalSmc::restore_split(BinaryReader& in, BinaryReader& trucks) {
  read_checkpoint_header(in, kCheckpointVersion, fingerprint_, sampler_.options().seed, [](std::uint32_t v) -> std::string {
    if (v == 1) {
      return "checkpoint format version 1 was written by the latent-variable core of ssrfleet 0.1; this build's "
             "default core reads version 4: replay the log into a new state directory";
    }
    if (v == 2) return "checkpoint format version 2 (before checksums): replay the log into a new state directory";
    if (v == 3) return "checkpoint format version 3 is the latent core's, not the marginal core's (4)";
    return "unsupported checkpoint format version " + std::to_string(v);
  });
  smc::TemperedSampler::State state;
  state.stages_run = in.value<std::int32_t>("stages_run");
  state.moves_run = in.value<std::int32_t>("moves_run");
  state.log_evidence = in.value<double>("log_evidence");
  state.log_weights = read_log_weights(in, sampler_.options().particles);
  const std::uint64_t n = target_.load_particles(in);
  truck_ids_.clear();
  for (std::uint64_t i = 0; i < n; ++i) {
    truck_ids_.push_back(trucks.text("truck_id"));
    target_.load_trucks(trucks, 1);
    trucks.check_seal("truck record");
  }
  drop_pool();
  site_trucks_.assign(sites_.size(), 0);
  recent_.assign(sites_.size(), {});
  const AbsorbedTrucks& a = target_.absorbed();
  for (std::size_t i = 0; i < a.size(); ++i) note_site(a.site(i), i);
  sampler_.restore(state);
}

}  // namespace ssrfleet::fleet
