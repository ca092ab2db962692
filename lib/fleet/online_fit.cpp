#include "fleet/online_fit.hpp"

#include <iomanip>
#include <sstream>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {

// What both cores share: the OnlineFit calls forwarded to the core.
template <class Core>
class CoreFit : public OnlineFit {
 public:
  template <class Sites, class Options>
  CoreFit(const Sites& sites, const Options& o) : smc_(sites, o) {}
  smc::StageSummary absorb(const records::WimRecord& record) override { return smc_.absorb(record); }
  void rejuvenate(int sweeps) override { smc_.rejuvenate(sweeps); }
  PosteriorCloud cloud() const override { return smc_.cloud(); }
  long trucks_seen() const override { return smc_.trucks_seen(); }
  std::size_t truck_id_count() const override { return smc_.truck_ids().size(); }
  std::string truck_id(std::size_t i) const override { return std::string(smc_.truck_ids()[i]); }
  const smc::TemperedSampler& sampler() const override { return smc_.sampler(); }
  void save(BinaryWriter& out) const override { smc_.save(out); }
  void restore(BinaryReader& in) override { smc_.restore(in); }
  long long integrator_passes() const override { return smc_.target().integrator_passes(); }

 protected:
  Core smc_;
};

class MarginalFit final : public CoreFit<MarginalSmc> {
 public:
  using CoreFit::CoreFit;
  std::string core() const override { return "marginal"; }
  void prepare(const std::vector<records::WimRecord>& records, std::size_t next) override { smc_.prepare(records, next); }
  std::string note() const override {
    return smc_.last_rebuild().empty() ? "" : "tables rebuilt (" + smc_.last_rebuild() + ")";
  }
  void visit_core(CoreVisitor& visitor) const override { visitor.on_marginal(smc_); }
  std::optional<double> table_seconds() const override { return smc_.target().table_seconds(); }
  bool holds_record(std::size_t i, const records::WimRecord& r) const override {
    const AbsorbedTrucks& a = smc_.target().absorbed();
    return a.site(i) == r.site && a.speed_mps(i) == r.speed_mps && a.sprung_mass_kg(i) == r.sprung_mass_kg &&
           a.impact_factors(i).size() == r.impact_factor.size() && a.impact_factors(i) == r.impact_factor;
  }
  std::unique_ptr<NewTruckProposals> table_proposals() const override {
    return std::make_unique<MarginalTableProposals>(smc_.target());
  }
  std::string warning() const override {
    const double e = smc_.target().lateral_error_mean();
    if (!(e > MarginalSmc::kLateralErrorWarning)) return "";
    std::ostringstream os;
    os << "the marginal core's lateral (z) approximation is off by " << std::setprecision(2) << e
       << " nats per truck on average here (budget " << MarginalSmc::kLateralErrorWarning
       << "): the sensors leave the trucks' lateral positions broad and many-peaked across the lane, "
          "so Z and sigma_z (and what depends on them) may be biased; compare with --core latent";
    return os.str();
  }
  bool splits_state() const override { return true; }
  void save_state(BinaryWriter& out) const override { smc_.save_state(out); }
  void save_trucks(BinaryWriter& out, std::size_t begin, std::size_t end) const override {
    smc_.save_trucks(out, begin, end);
  }
  int table_generation() const override { return smc_.table_generation(); }
  void restore_split(BinaryReader& state, BinaryReader& trucks) override { smc_.restore_split(state, trucks); }
};

class LatentFit final : public CoreFit<FleetSmc> {
 public:
  using CoreFit::CoreFit;
  std::string core() const override { return "latent"; }
  smc::StageSummary absorb(const records::WimRecord& record) override {
    if (record.site != 0) throw UsageError("the latent core fits one site; several sites need the marginal core");
    return smc_.absorb(record);
  }
  void visit_core(CoreVisitor& visitor) const override { visitor.on_latent(smc_); }
};

}  // namespace

std::unique_ptr<OnlineFit> make_online_fit(const site::Site& site, const OnlineFitOptions& options) {
  return make_online_fit(std::vector<const site::Site*>{&site}, options);
}

std::string OnlineFitOptions::marginal_refusal(const ModelExtension& extension) {
  return "model '" + extension.name() + "' is not carried by the marginal core, which fits the base model, second_class "
         "and the one-parameter effects inside the dynamics (tyre_damping, unsprung_mass, suspension_damping, "
         "speed_bias) and a gain on a given sensor (sensor_gain:sensor=N); a gain with the sensor free (a discrete "
         "choice), a profile defect and compositions of several effects are not yet carried: fit it on the latent core (--core latent, the default for this model)";
}

Core choose_core(const ModelExtension* extension, std::optional<Core> requested) {
  if (requested) {
    if (*requested == Core::kMarginal && !OnlineFitOptions::marginal_carries(extension)) {
      throw UsageError(OnlineFitOptions::marginal_refusal(*extension));
    }
    return *requested;
  }
  if (!OnlineFitOptions::marginal_carries(extension)) return Core::kLatent;
  const bool windowed = extension != nullptr && carried_by_psi_window(extension);
  return !windowed || psi_window_by_default(extension) ? Core::kMarginal : Core::kLatent;
}

std::unique_ptr<OnlineFit> make_online_fit(const std::vector<const site::Site*>& sites, const OnlineFitOptions& options) {
  if (sites.empty()) throw UsageError("make_online_fit: no site");
  if (options.core == OnlineFitOptions::Core::kMarginal) {
    std::string why;
    if (!options.marginal.sampler.IsValid(&why)) throw UsageError(why);
    choose_core(options.extension, options.core);  // UsageError if the marginal core does not carry the model
    MarginalSmc::Options marginal = options.marginal;
    marginal.target.extension = options.extension;
    return std::make_unique<MarginalFit>(sites, marginal);
  }
  if (sites.size() > 1) {
    throw UsageError("a fit of several sites runs on the marginal core (each truck's table is built through its own "
                     "site); the latent core (--core latent, or --model with an effect it alone carries) fits one site");
  }
  std::string why;
  if (!options.latent.sampler.IsValid(&why)) throw UsageError(why);
  FleetSmc::Options latent = options.latent;
  if (options.extension != nullptr) latent.extension = options.extension;
  return std::make_unique<LatentFit>(*sites.front(), latent);
}

}  // namespace ssrfleet::fleet
