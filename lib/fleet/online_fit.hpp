// One driver shape for every command that feeds trucks to a sampler (fit, stream, reproduce,
// diagnose; the offline ones through replay.hpp):
// absorb a record, rejuvenate after an offline replay, hand out the posterior, checkpoint. Two
// cores implement it:
//   marginal (default)  MarginalSmc: IBIS over θ with each truck's latents integrated out in a
//                       table; cost per truck flat in n (docs/inference.md);
//   latent              FleetSmc: every truck's latents in every particle, older trucks re-swept
//                       per truck (cost grows with n); needed for the effects the marginal core
//                       does not carry (marginal_carries: a gain with its sensor free, a profile defect and
//                       compositions of several effects).
// Which core a model fits on is decided in one place, choose_core. Callers see the core through
// OnlineFit's methods alone; what only one core can give (posterior draws of every truck's
// latents, the sensor gains' M-step) is reached through a CoreVisitor, so that no caller asks
// which core it holds and casts.
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "fleet/fleet_smc.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/new_truck_proposals.hpp"
#include "fleet/posterior_cloud.hpp"
#include "util/binary_io.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"
#include "smc/engine.hpp"

namespace ssrfleet::fleet {

// What needs one core in particular: the core calls the method of its kind (OnlineFit::visit_core).
class CoreVisitor {
 public:
  virtual ~CoreVisitor() = default;
  virtual void on_latent(const FleetSmc& core) = 0;
  virtual void on_marginal(const MarginalSmc& core) = 0;
};

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
  // Calls visitor.on_latent or visitor.on_marginal with the core itself (see visit_core below).
  virtual void visit_core(CoreVisitor& visitor) const = 0;
  // Quarter-car integrator passes so far (building tables, re-simulating trucks), the fit's cost
  // in the unit that does not depend on the machine.
  virtual long long integrator_passes() const = 0;
  // Seconds this process spent building truck tables; nullopt for a core without tables.
  virtual std::optional<double> table_seconds() const { return std::nullopt; }
  // Whether the truck absorbed i-th (i < trucks_seen()) holds `record`'s data (site, speed, sprung
  // mass, impact factors), so a resumed fit can refuse a log edited since; true for a core that
  // keeps no record data of its own to compare.
  virtual bool holds_record(std::size_t /*i*/, const records::WimRecord& /*record*/) const { return true; }
  // The fit's truck tables as proposals for a latent-core fit of the same records in the same
  // order (new_truck_proposals.hpp); null for a core without tables. Refers to this fit, which must
  // outlive it.
  virtual std::unique_ptr<NewTruckProposals> table_proposals() const { return nullptr; }
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

// The two inference cores (see the top of this file).
enum class Core { kMarginal, kLatent };

struct OnlineFitOptions {
  using Core = fleet::Core;
  // Set it with choose_core.
  Core core = Core::kMarginal;
  // The model extension fitted alongside θ (not owned; outlives the fit), or null for the base
  // model. make_online_fit hands it to the chosen core.
  const ModelExtension* extension = nullptr;
  // Whether the marginal core carries a model: the base model, extensions that change the fleet's
  // stiffness distribution alone (their mixture reweights the tables' nodes exactly), and
  // one-parameter effects inside the dynamics (tables at the nodes of a ψ window,
  // marginal_psi_window.hpp), a gain on a given sensor among them. A discrete choice (sensor_gain
  // with its sensor free), an added profile (profile_defect) and compositions of several effects
  // need the latent core.
  static bool marginal_carries(const ModelExtension* extension) {
    return extension == nullptr || !extension->edits_forward() || carried_by_psi_window(extension);
  }
  // Why the marginal core refuses a model it does not carry (names the latent core).
  static std::string marginal_refusal(const ModelExtension& extension);
  MarginalSmc::Options marginal;
  FleetSmc::Options latent;
  // The sampler options shared by both (particles, threads, seed): copied into the chosen core's.
  smc::TemperedSampler::Options& sampler() { return core == Core::kMarginal ? marginal.sampler : latent.sampler; }
  int default_final_sweeps() const {
    return core == Core::kMarginal ? marginal.sampler.schedule.final_sweeps : latent.sampler.schedule.final_sweeps;
  }
};

// The core a model (extension, null for the base model) fits on: `requested` if given and it
// carries the model (UsageError with marginal_refusal's text if the marginal core is asked for a
// model it does not carry; the latent core carries every model); otherwise the marginal core
// wherever it carries the model (its cost per truck is flat in n) at a reasonable cost, else the
// latent core (psi_window_by_default says which carried effects are too dear by default).
Core choose_core(const ModelExtension* extension, std::optional<Core> requested = std::nullopt);

// visit_core with one callable per core, both returning the same type: the value of the one called.
template <class OnLatent, class OnMarginal>
auto visit_core(const OnlineFit& fit, OnLatent&& on_latent, OnMarginal&& on_marginal) {
  using Result = std::invoke_result_t<OnMarginal&, const MarginalSmc&>;
  class Visitor final : public CoreVisitor {
   public:
    Visitor(OnLatent& l, OnMarginal& m) : l_(l), m_(m) {}
    void on_latent(const FleetSmc& core) override { result.emplace(l_(core)); }
    void on_marginal(const MarginalSmc& core) override { result.emplace(m_(core)); }
    std::optional<Result> result;

   private:
    OnLatent& l_;
    OnMarginal& m_;
  };
  Visitor visitor(on_latent, on_marginal);
  fit.visit_core(visitor);
  return std::move(*visitor.result);
}

// UsageError if the options are invalid (among them a core that does not carry the model:
// choose_core's check).
std::unique_ptr<OnlineFit> make_online_fit(const site::Site& site, const OnlineFitOptions& options);
// One fleet over several sites (fleet/joint_sites.hpp): a record's `site` indexes `sites`, which must
// outlive the fit. The marginal core only; UsageError for the latent core and more than one site.
std::unique_ptr<OnlineFit> make_online_fit(const std::vector<const site::Site*>& sites, const OnlineFitOptions& options);

}  // namespace ssrfleet::fleet
