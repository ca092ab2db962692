// One driver shape for every command that feeds trucks to a sampler (fit, stream, reproduce,
// diagnose; the offline ones through replay.hpp):
// absorb a record, rejuvenate after an offline replay, hand out the posterior, checkpoint. Two
// cores implement it:
//   marginal (default)  MarginalSmc: IBIS over θ with each truck's latents integrated out in a
//                       table; cost per truck flat in n (docs/inference.md);
//   latent              FleetSmc: every truck's latents in every particle, older trucks re-swept
//                       per truck (cost grows with n); needed for the effects the marginal core
//                       does not carry (marginal_carries: a sensor gain, a profile defect and
//                       compositions of several effects).
#pragma once

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "fleet/fleet_smc.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/posterior_cloud.hpp"
#include "util/binary_io.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"
#include "smc/engine.hpp"

namespace ssrfleet::fleet {

class OnlineFit {
 public:
  virtual ~OnlineFit() = default;
  virtual smc::StageSummary absorb(const records::WimRecord& record) = 0;
  // Before absorb(records[next]) in an offline replay: a core may do ahead, in parallel, work
  // that the next records' absorbs would do one by one (the marginal core builds their tables).
  // Only a speed-up: the results are the same bits without it.
  virtual void prepare(const std::vector<records::WimRecord>& /*records*/, std::size_t /*next*/) {}
  // MCMC sweeps at φ = 1 after the last record of an offline replay (the posterior is unchanged).
  virtual void rejuvenate(int sweeps) = 0;
  virtual PosteriorCloud cloud() const = 0;
  virtual long trucks_seen() const = 0;
  // The ids of the trucks absorbed, in order (the latent core with a window keeps the last ones only).
  virtual std::size_t truck_id_count() const = 0;
  virtual std::string truck_id(std::size_t i) const = 0;
  virtual const smc::TemperedSampler& sampler() const = 0;
  virtual void save(BinaryWriter& out) const = 0;
  virtual void restore(BinaryReader& in) = 0;
  virtual std::string core() const = 0;  // "marginal" or "latent"
  // The latent core itself, for what only it has (every truck's latents, an extension's ψ);
  // nullptr for the marginal core.
  virtual const FleetSmc* latent() const { return nullptr; }
  // The marginal core itself (its tables' diagnostics); nullptr for the latent core.
  virtual const MarginalSmc* marginal() const { return nullptr; }
  // A line for progress output after absorb(): what the last record cost beyond its stage.
  virtual std::string note() const { return ""; }
  // What the user should know about the posterior's quality ("" if nothing), e.g. an
  // approximation that the data push past its budget.
  virtual std::string warning() const { return ""; }

  // A state in two parts for a stream, so its checkpoint per truck costs O(1): a fixed-size part
  // and a log of truck records to append to (whole again after table_generation() moves on).
  // A core without the split keeps one state (save/restore) and writes no truck log.
  virtual bool splits_state() const { return false; }
  virtual void save_state(BinaryWriter& out) const { save(out); }
  virtual void save_trucks(BinaryWriter& /*out*/, std::size_t /*begin*/, std::size_t /*end*/) const {}
  virtual int table_generation() const { return 0; }
  virtual void restore_split(BinaryReader& state, BinaryReader& /*trucks*/) { restore(state); }
};

struct OnlineFitOptions {
  enum class Core { kMarginal, kLatent };
  Core core = Core::kMarginal;
  // The model extension fitted alongside θ (not owned; outlives the fit), or null for the base
  // model. make_online_fit hands it to the chosen core.
  const ModelExtension* extension = nullptr;
  // Whether the marginal core carries a model: the base model, extensions that change the fleet's
  // stiffness distribution alone (their mixture reweights the tables' nodes exactly), and
  // one-parameter effects inside the dynamics (tables at the nodes of a ψ window,
  // marginal_psi_window.hpp). A discrete choice (sensor_gain), an added profile (profile_defect)
  // and compositions of several effects need the latent core.
  static bool marginal_carries(const ModelExtension* extension) {
    return extension == nullptr || !extension->edits_forward() || carried_by_psi_window(extension);
  }
  // Why the marginal core refuses a model it does not carry (names the latent core).
  static std::string marginal_refusal(const ModelExtension& extension);
  // The core a model fits on unless the user names one: the marginal core wherever it carries the
  // model (its cost per truck is flat in n) at a reasonable cost, else the latent core
  // (psi_window_by_default says which carried effects are too dear by default).
  static Core default_core(const ModelExtension* extension) {
    if (!marginal_carries(extension)) return Core::kLatent;
    const bool windowed = extension != nullptr && carried_by_psi_window(extension);
    return !windowed || psi_window_by_default(extension) ? Core::kMarginal : Core::kLatent;
  }
  MarginalSmc::Options marginal;
  FleetSmc::Options latent;
  // The sampler options shared by both (particles, threads, seed): copied into the chosen core's.
  smc::TemperedSampler::Options& sampler() { return core == Core::kMarginal ? marginal.sampler : latent.sampler; }
  int default_final_sweeps() const {
    return core == Core::kMarginal ? marginal.sampler.schedule.final_sweeps : latent.sampler.schedule.final_sweeps;
  }
};

// UsageError if the options are invalid.
std::unique_ptr<OnlineFit> make_online_fit(const site::Site& site, const OnlineFitOptions& options);
// One fleet over several sites (fleet/joint_sites.hpp): a record's `site` indexes `sites`, which must
// outlive the fit. The marginal core only; UsageError for the latent core and more than one site.
std::unique_ptr<OnlineFit> make_online_fit(const std::vector<const site::Site*>& sites, const OnlineFitOptions& options);

}  // namespace ssrfleet::fleet
