// Online fleet inference on the marginal core (docs/inference.md): each WIM record is one IBIS stage
// over the 7 hyperparameters, its likelihood ℓ_n(θ) read from the table built when it arrives
// (marginal_target.hpp). MCMC moves run only after a resampling, so move phases come a few times
// per doubling of n and the cost per truck stays flat. When the posterior has moved away from the
// settings the tables were built for, the tables are rebuilt and the change tempered in as a
// correction stage (not counted in the evidence).
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "fleet/marginal_target.hpp"
#include "fleet/posterior_cloud.hpp"
#include "util/binary_io.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"
#include "smc/engine.hpp"
#include "util/spill_strings.hpp"

namespace ssrfleet::fleet {

class MarginalSmc {
 public:
  struct Options {
    // The move schedule (smc/move_schedule.hpp), IBIS: moves only after a resampling. Each sweep
    // proposes independently from a t fitted to the cloud, with a random-walk step while that
    // accepts below 0.3 (the first trucks); sweeps repeat until the cloud has moved half a
    // posterior sd per coordinate, at most 30. After an offline replay's last truck (fit),
    // final_sweeps = 15 sweeps: measured on the paper's 100-truck case (8 seeds), the smallest
    // equivalent ESS of the posterior means was 225 after 3 final sweeps and 614 after 15, at
    // 1.4 s and 1.9 s for the whole fit.
    smc::TemperedSampler::Options sampler = [] {
      smc::TemperedSampler::Options o;
      o.particles = 1024;
      o.schedule = smc::MoveSchedule::ibis_independence(/*max_sweeps=*/30, /*final_sweeps=*/15);
      return o;
    }();
    MarginalTarget::Options target;  // its particles follow sampler.particles
    // rejuvenate() pools at most this many draws (particles × sweeps): beyond it, only the last
    // max_pooled_draws / particles sweeps (at least one). 10^6 draws are about 56 MB in memory and
    // 150 MB of posterior file, well inside the file limit (io/posterior_json.hpp, 1 GiB) that
    // predict reads; the default fit pools 15 × 1,024.
    std::int64_t max_pooled_draws = 1'000'000;
  };

  // Above this mean |error| of the tables' lateral approximation (nats per truck,
  // MarginalTarget::lateral_error_mean) a fit warns: on road AS1 it is about 1e-4. On AS2 with a
  // second fleet, before the tables cut broad z-likelihoods into pieces, it was 0.1-0.2 and σ_z
  // came out 0.59 against a truth of 0.35; with the pieces it is below 1e-3.
  static constexpr double kLateralErrorWarning = 0.01;

  MarginalSmc(const site::Site& site, Options options) : MarginalSmc(std::vector<const site::Site*>{&site}, std::move(options)) {}
  // One fleet over several sites (fleet/joint_sites.hpp): a record's `site` indexes `sites`.
  MarginalSmc(std::vector<const site::Site*> sites, Options options);

  // Tempers the record's likelihood in (and rebuilds the tables if the posterior asks for it).
  // Returns the record's stage summary.
  smc::StageSummary absorb(const records::WimRecord& record);
  // Before absorb(records[next]): builds the tables of the records from `next` on that the frozen
  // table options cover, one truck per thread (MarginalTarget::prebuild). Only a speed-up for an
  // offline replay: absorb() gives the same bits without it.
  void prepare(const std::vector<records::WimRecord>& records, std::size_t next);
  // MCMC sweeps at φ = 1 (the posterior is unchanged; the cloud's duplicates spread out). Every
  // sweep's cloud is a weighted draw of the same posterior, so all of them are kept and cloud()
  // hands out their pool (sweeps × particles draws, each particle's weight shared over its copies)
  // until the next absorb(): the "waste-free" use of a final phase (Dau & Chopin 2022). Measured
  // on 1,000 Table 1 trucks, 8 SMC seeds, 15 sweeps (ratio_benchmark): the smallest equivalent ESS
  // of the posterior means (seed scatter) 3,329 for the pool against 403 for the last cloud alone,
  // from the same fits. At most Options::max_pooled_draws draws are kept (the last sweeps').
  smc::MhSummary rejuvenate(int sweeps);
  // Clouds pooled by the last rejuvenate() (0 once a truck has been absorbed since).
  int pooled_sweeps() const { return static_cast<int>(pooled_theta_.cols() / options_.sampler.particles); }

  long trucks_seen() const { return static_cast<long>(target_.trucks()); }
  const MarginalTarget& target() const { return target_; }
  const smc::TemperedSampler& sampler() const { return sampler_; }
  // The posterior: the pool of the last rejuvenate()'s sweeps if no truck came since, else the
  // current weighted particles (current_cloud()).
  PosteriorCloud cloud() const;
  PosteriorCloud current_cloud() const;
  // The absorbed trucks' ids, in order (in the tables' spill directory when they have one).
  const util::SpillStringList& truck_ids() const { return truck_ids_; }
  // What the last absorb() rebuilt, if anything ("" = nothing).
  const std::string& last_rebuild() const { return last_rebuild_; }

  // Checkpoint of everything the next truck depends on, so a restored run continues bit-identically.
  void save(BinaryWriter& out) const;
  void restore(BinaryReader& in);
  // The same in two parts for a stream (O(1) per truck): the particles and settings, and the
  // trucks [begin, end) (id, data, fit, table), which a stream appends to a log. A rebuild of the
  // tables changes every truck's record: table_generation() then moves on, and the whole log must
  // be written again. restore_split() reads the state, then as many truck records as it names.
  void save_state(BinaryWriter& out) const;
  void save_trucks(BinaryWriter& out, std::size_t begin, std::size_t end) const;
  void restore_split(BinaryReader& state, BinaryReader& trucks);
  // A state read from truck records of an older format counts as a generation of its own
  // (kMigratedGeneration apart), so its log is written anew in this build's format, never appended to.
  int table_generation() const { return target_.rebuilds() + (target_.read_old_truck_records() ? kMigratedGeneration : 0); }
  static constexpr int kMigratedGeneration = 1 << 24;

  // Observed (speed, mass) pairs that predictions draw from: the most recent ones, so a year-long
  // stream's posterior file stays the same size. Over several sites, each site's most recent
  // kPredictionPool / sites (at least kMinSitePool), so a site's prediction draws its own traffic.
  static constexpr std::size_t kPredictionPool = 10000;
  static constexpr std::size_t kMinSitePool = 500;

 private:
  std::vector<const site::Site*> sites_;
  std::string fingerprint_;  // sites_fingerprint(sites_): what the checkpoint is tied to
  // Several sites: each site's trucks so far and its most recent ones (indices, oldest first, at
  // most its share of kPredictionPool), kept as trucks arrive (not checkpointed: rebuilt on restore).
  void note_site(std::uint32_t site, std::size_t truck);
  std::vector<long> site_trucks_;
  std::vector<std::deque<std::size_t>> recent_;
  Options options_;
  MarginalTarget target_;
  smc::TemperedSampler sampler_;
  smc::ParallelFor parallel_;
  util::SpillStringList truck_ids_;
  std::string last_rebuild_;
  // θ after each pooled sweep of the last rejuvenate(), side by side (kHyperCount × sweeps · P;
  // no columns: no pool). A report of the final phase, not state: never checkpointed (a resumed
  // fit runs the sweeps again).
  Eigen::MatrixXd pooled_theta_;
  Eigen::MatrixXd pooled_psi_;  // the extension's ψ beside pooled_theta_ (no rows without one)
  void drop_pool() {
    pooled_theta_.resize(kHyperCount, 0);
    pooled_psi_.resize(pooled_psi_.rows(), 0);
  }
};

}  // namespace ssrfleet::fleet
