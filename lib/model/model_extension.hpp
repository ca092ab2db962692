// A named extension of the fleet model (docs/model.md): one physical effect the base quarter-car
// model leaves out, with its own parameters ψ and their uniform priors. The fleet target fits ψ
// alongside θ and the trucks' latents (fleet_target.hpp); the simulator can switch the effect on
// to make data in which it is hidden (simulator.hpp); `diagnose` scores each extension by
// evidence (lib/discrepancy).
//
// An extension changes the forward model through up to three hooks, applied in this order to
// every simulated pass (edits_forward() says whether it has any):
//   edit_pass    the pass's inputs (vehicle constants, the speed the car really drove at);
//   add_profile  a height added to every wheel path (the same at every lateral position), e.g. a
//                local defect missing from the road file; the system is linear, so its effect is
//                simulated on its own and added (extended_forward.cpp);
//   edit_output  what the sensors report (e.g. a calibration gain).
// It may also change the fleet model, the distribution of the suspension stiffness k across
// trucks (edits_stiffness_distribution, e.g. a second class of trucks): the fleet target then
// uses its density and draws, and the simulator lets it edit each simulated truck.
// Each catalogue entry lives in one file under lib/model/effects/ and registers itself
// with ExtensionRegistrar, so adding an effect is one new file.
#pragma once

#include <functional>
#include <iterator>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "records/truck.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

// The posterior predictive checks of lib/discrepancy, by what they locate. An extension names the
// checks its effect would fail (its signature), so `diagnose` refits only plausible candidates.
enum class CheckKind : int {
  kSensorMean = 0,   // per-sensor mean residual
  kSensorDispersion, // per-sensor residual variance against σ_IF²
  kSpeed,            // residuals against speed
  kMass,             // residuals against sprung mass
  kLateral,          // residuals against the lateral position
  kAutocorrelation,  // lag-1 autocorrelation of residuals along the sensor array
  kStiffnessDistribution,  // the trucks' suspension stiffnesses against the fleet distribution
  kLatentCovariates,       // the trucks' stiffnesses (k, k_t) against their speed and sprung mass
  kCount
};
inline constexpr std::string_view kCheckNames[] = {"sensor_mean", "sensor_dispersion", "speed",
                                                   "mass",        "lateral",           "autocorrelation",
                                                   "stiffness_distribution", "latent_covariates"};
static_assert(std::size(kCheckNames) == static_cast<std::size_t>(CheckKind::kCount), "a name for every check");
inline std::string_view check_name(CheckKind c) { return kCheckNames[static_cast<int>(c)]; }

struct ExtensionParameter {
  std::string name;          // JSON key
  std::string unit;          // for reports ("" = dimensionless)
  double lo = 0.0, hi = 1.0; // uniform prior
  double null_value = 0.0;   // the value at which the extension is the base model
};

// Everything one simulated pass depends on. The fleet model fills it from the record (speed,
// sprung mass), the truck's latents (k, k_t, z) and the site's constants; extensions edit it.
struct PassSetup {
  double speed_mps = 0.0;
  double sprung_mass_kg = 0.0;
  double unsprung_mass_kg = 0.0;
  double stiffness_npm = 0.0;
  double suspension_damping_nspm = 0.0;
  double tyre_stiffness_npm = 0.0;
  double tyre_damping_nspm = 0.0;
  double lateral_m = 0.0;
};

class ModelExtension {
 public:
  virtual ~ModelExtension() = default;

  virtual std::string name() const = 0;         // canonical name (docs/model.md)
  virtual std::string description() const = 0;  // one line for reports
  virtual const std::vector<ExtensionParameter>& parameters() const = 0;
  virtual std::vector<CheckKind> signature() const = 0;

  // psi points at parameters().size() values inside their prior box.
  virtual void edit_pass(const double* /*psi*/, PassSetup& /*pass*/) const {}
  virtual bool adds_profile() const { return false; }
  // profile: the site's samples (spacing dx_m from x = 0), zero on entry; add the effect's
  // height in metres, as the tyre feels it (after envelopment).
  virtual void add_profile(const double* /*psi*/, double /*dx_m*/, Eigen::Ref<Eigen::ArrayXd> /*profile*/) const {}
  // impact_factor: one pass's model IF at the site's sensors, edited in place.
  virtual void edit_output(const double* /*psi*/, Eigen::Ref<Eigen::ArrayXd> /*impact_factor*/) const {}
  // False when none of the three hooks above does anything, so a pass needs no extended forward
  // model and ψ can move without re-simulating a truck.
  virtual bool edits_forward() const { return true; }

  // The fleet model: k ~ N(K, σ_k²) across trucks in the base model. An extension that replaces
  // that distribution overrides all four of the following consistently.
  virtual bool edits_stiffness_distribution() const { return false; }
  // log p(k | K, σ_k, ψ).
  virtual double log_stiffness_density(const double* psi, double k, double mean_npm, double sd_npm) const;
  // P(K ≤ k | K, σ_k, ψ): the checks compare the trucks' k with it.
  virtual double stiffness_cdf(const double* psi, double k, double mean_npm, double sd_npm) const;
  // A draw of k from p(k | K, σ_k, ψ) made from a uniform on [0, 1) and an independent standard
  // normal, so the caller's random stream decides.
  virtual double draw_stiffness(const double* psi, double mean_npm, double sd_npm, double uniform,
                                double standard_normal) const;
  // The same distribution as a mixture of normals, Σ_c w_c N(k | m_c, s_c²) (components with
  // weight 0 may be left out): how the marginal core weights its (k, k_t) lattice's nodes
  // (model/fleet_marginal.hpp), each component's sd held to the lattice's floor on its own. The
  // base model's is one component, N(K, σ_k²). Must agree with log_stiffness_density.
  struct StiffnessComponent {
    double weight = 1.0, mean_npm = 0.0, sd_npm = 0.0;
  };
  virtual std::vector<StiffnessComponent> stiffness_mixture(const double* psi, double mean_npm, double sd_npm) const;
  // Simulation: turns a truck drawn from the base fleet (simulator.hpp) into one of the extended
  // fleet, from a uniform and a standard normal of its own (e.g. moves it to the second class).
  virtual void edit_simulated_truck(const double* /*psi*/, records::Truck& /*truck*/, double /*uniform*/,
                                    double /*standard_normal*/) const {}

  // Optional: a jump between modes of ψ that are far apart and that the data tell apart only
  // slowly (aliases). The fleet target's random walk, scaled on the particle cloud, cannot cross
  // from one to the other once the cloud has settled in one of them, so it mixes this proposal
  // in (FleetTarget::Options::extension_jump_sweeps). `u` holds jump_draws() uniforms on [0, 1);
  // the proposal must be symmetric: ψ' as likely from ψ as ψ from ψ' (it may leave the prior
  // box; such proposals are rejected).
  virtual int jump_draws() const { return 0; }  // 0: no jump
  virtual void jump(const double* /*psi*/, const double* /*u*/, double* /*psi_out*/) const {}

  // Optional, for an extension that replaces the stiffness distribution and does not edit the
  // forward model: a jump of (K, σ_k, ψ) together between distant modes of their conditional
  // (log_stiffness_conditional), e.g. the two classes of a mixture trading places. `u` holds
  // stiffness_jump_draws() uniforms on [0, 1); the proposal must be symmetric (it may leave a box;
  // such proposals are rejected). Both samplers run it with their "stiffness distribution" steps.
  virtual int stiffness_jump_draws() const { return 0; }  // 0: no jump
  virtual void stiffness_jump(const double* /*psi*/, double /*mean_npm*/, double /*sd_npm*/, const double* /*u*/,
                              double* /*psi_out*/, double* /*mean_out*/, double* /*sd_out*/) const {}

  // Optional: the coordinates u = g(ψ) in which both samplers' random walks on ψ step (a smooth
  // bijection of the box's interior; ψ stays what users see in reports and settings). A posterior
  // ridge that is curved in ψ but straight in u is then followed by a walk whose covariance is
  // fitted to the chain or the cloud. The default is ψ itself. A walk in u targets
  // π(ψ(u)) |det ∂ψ/∂u|, so its MH ratio gains log_move_jacobian(ψ') - log_move_jacobian(ψ).
  virtual void to_move_coordinates(const double* psi, double* u) const;
  virtual void from_move_coordinates(const double* u, double* psi) const;
  virtual double log_move_jacobian(const double* /*psi*/) const { return 0.0; }  // log |det ∂ψ/∂u|
  // How far each move coordinate u_j moves as ψ_j crosses its box with the others at their null
  // values (the box's width for ψ itself): the scale both samplers start or floor their walks at.
  std::vector<double> move_coordinate_spans() const;

  // Optional: the index of a parameter that names one of the site's sensors (a whole number in
  // [1, M], its box [0.5, M + 0.5]), or -1. The per-sensor posterior predictive checks point at a
  // sensor, so `diagnose` can fix such a parameter there and fit the rest on the flat-cost core
  // (the fixed model's evidence, less log M for the sensor's prior mass, bounds the full model's
  // from below).
  virtual int sensor_parameter() const { return -1; }

  Eigen::Index dim() const { return static_cast<Eigen::Index>(parameters().size()); }
  bool in_prior(const double* psi) const;
  // The uniform prior's log density (the normalised box), -inf outside.
  double log_prior(const double* psi) const;
};

// The catalogue. A factory builds an extension for one site (priors may depend on the sensors and
// the road's length).
using ExtensionFactory = std::function<std::unique_ptr<ModelExtension>(const site::Site&)>;

struct ExtensionRegistrar {
  ExtensionRegistrar(std::string name, ExtensionFactory factory);
};

// Registered names, sorted.
std::vector<std::string> extension_names();
// UsageError listing the catalogue if the name is unknown.
std::unique_ptr<ModelExtension> make_extension(const std::string& name, const site::Site& site);

// "name:p1=v1,p2=v2" with every parameter of the extension given once, inside its prior box →
// the extension and ψ (e.g. "sensor_gain:sensor=5,gain=1.05"). UsageError naming the bad part.
struct ExtensionSetting {
  std::unique_ptr<ModelExtension> extension;
  std::vector<double> psi;
};
ExtensionSetting parse_extension_setting(const std::string& text, const site::Site& site);

}  // namespace ssrfleet::fleet
