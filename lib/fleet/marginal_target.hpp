// The fleet posterior on the hyperparameters alone, π_n(θ) ∝ p(θ) Π_i ℓ_i(θ) (docs/inference.md), as
// a target for the generic tempered SMC engine. Each particle is one θ (7 numbers); the trucks'
// latents are integrated out in their tables (model/truck_table.hpp), so a particle's state does
// not grow with n and one θ move costs one pass over the tables, with no integrator call.
//
// A stage is one of three kinds, set by the driver before it runs the stage:
//   truck       add_truck(): log γ = log p(θ) + Σ_{i<n} ℓ_i(θ), increment ℓ_n(θ) (IBIS);
//   correction  begin_rebuild(): the tables are rebuilt on a lattice and σ_ref that follow the
//               posterior, and the ratio of the new approximation to the old one is tempered in
//               (log γ = log p(θ) + Σ ℓ_i^old, increment Σ ℓ_i^new - Σ ℓ_i^old);
//   idle        after finish_stage(): every truck in log γ, no increment (rejuvenation moves).
// Per particle the target caches Σ ℓ_i over the trucks in log γ and the increment, so the
// engine's stage start costs O(1) per particle for a truck stage.
//
// The tables' settings follow the posterior (TableSettings): the lattice spacing is a fraction of
// the narrowest integrand width in (k, k_t) that the posterior allows, σ_ref is the posterior mean
// of σ_IF (the Laplace form in σ_IF is exact at σ_ref and accurate near it), and the population
// that decides which nodes a table keeps is the posterior predictive of (k, k_t), widened. When
// the posterior has moved away from the settings the tables were built with, rebuild_reason()
// says why, and the driver runs a correction stage; rebuilds are spaced geometrically in n, so
// their cost is O(1) per truck amortised.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fleet/absorbed_trucks.hpp"
#include "model/fleet_model.hpp"
#include "util/binary_io.hpp"
#include "model/fleet_marginal.hpp"
#include "fleet/marginal_psi_window.hpp"
#include "model/model_extension.hpp"
#include "model/psi_grid.hpp"
#include "model/table_store.hpp"
#include "model/truck_table.hpp"
#include "site/site.hpp"
#include "smc/target.hpp"
#include "util/exact_sum.hpp"
#include "util/ranks.hpp"

namespace ssrfleet::fleet {

class MarginalTarget final : public smc::TemperedModel {
 public:
  struct Options {
    Eigen::Index particles = 1024;
    PriorBounds prior;
    // keep_nats, the lateral window and the quadrature; sigma_ref and population are set here.
    model::TruckTableOptions table;
    // Node spacing as a fraction of the integrand width (at the fleet sds' low quantile, below).
    // The rectangle rule's error on a lattice of spacing f x width falls like exp(-2π²/f²):
    // measured against a 73 x 73 rule on 8 AS1 and 8 AS2 trucks (z integrated exactly at every
    // node, 10 values of θ around the fleet's), f = 0.7 and f = 1.0 both err by at most 4e-6
    // nats per truck on AS1 and 8e-5 on AS2 (a ridge-shaped likelihood, correlation -0.75), with
    // 0.49 times the nodes at 1.0; at 1.4 a fleet sd of half the usual errs by up to 1e-3. At
    // f = 1 the rule's error summed over n trucks, 2 n exp(-2π²), stays under 0.1 nat at the
    // quantile up to n = 10^7, and FleetMarginal's floor (a fleet sd below 0.8 spacings is
    // evaluated there) sits at 0.8 of the quantile.
    double lattice_fraction = 1.0;
    // ... at this quantile of the fleet sds' posterior, but at least this fraction of their median
    // (so a broad early posterior does not make the lattice explode). At the 2 % quantile the floor
    // reached into the posterior's lower tail: on road AS2 (second fleet, 1,000 trucks, σ_kt
    // 170k ± 44k) one of 50 posterior draws had σ_kt below it and the tables put it 2.4 nats too
    // high; at the median the SMC's σ_kt sd came out 24 % too wide (49.6k against 40k, 4 seeds).
    // The quantile is a lognormal's fitted to the cloud's log σ (weighted mean and sd), not the
    // particles' own: theirs at 0.1 % is the lowest one or two, whose noise refined the lattice and
    // rebuilt it more often (1,000 Table 1 trucks, 1 thread: 1.30 times the 2 % rule's CPU, against
    // 1.13 with the lognormal's).
    double lattice_sd_quantile = 0.001;
    double lattice_sd_min_of_median = 0.3;
    // Which nodes a table keeps is judged against the posterior predictive of (k, k_t) with its sd
    // multiplied by this (so the fleet may move a good way before dropped nodes matter).
    double population_widening = 1.3;
    // Rebuild when the posterior mean of σ_IF is this far from σ_ref in log (the Laplace form's
    // error grows like the cube of the distance: ~1e-3 nats at 0.1, ~1e-4 at 0.05).
    double sigma_ref_tolerance = 0.05;
    // Rebuild when the ideal spacing has moved outside [spacing / too_coarse, spacing / too_fine].
    // A lattice too fine costs nodes, not accuracy; the spacing follows a low quantile of the fleet
    // sds, which rises as their posterior narrows, so at 0.6 the tables carried up to 2.8x the
    // nodes they need (363 against 256 per table at 1,000 Table 1 trucks).
    double too_coarse = 1.25, too_fine = 0.8;
    // Rebuilds at most at n >= rebuild_growth × (n at the last rebuild): O(1) cost per truck.
    double rebuild_growth = 1.5;
    // A ψ window the posterior has moved out of (marginal_psi_window.hpp) is rebuilt sooner, at
    // n >= psi_moved_growth × (n at the last rebuild): at most 1 / (psi_moved_growth - 1) tables per
    // truck and node amortised in the worst case.
    double psi_moved_growth = 1.1;
    // A table cuts a node's broad z-likelihood into pieces no broader (in sd) than this fraction of
    // σ_z's posterior 10 % quantile, within [min_piece_sd_m, table.max_piece_sd_m]: the moment
    // matching of the lateral prior then errs by well under 1e-3 nats per truck (model/truck_table.hpp,
    // "Pieces"). Measured on road AS2, 8 trucks against the brute-force integral at σ_z = 0.35 m:
    // pieces of sd 0.2 / 0.1 / 0.05 m err by up to 0.029 / 0.011 / 0.004 nats per truck (typically
    // 0.02 / 0.004 / 0.0003), one Gaussian per node by up to 0.23.
    double lateral_piece_fraction = 1.0 / 6.0;
    double min_piece_sd_m = 0.04;
    // The cloud-dependent options of a new truck's table (which nodes it keeps, the search's
    // start, the piece limit) are frozen for the next max(1, min(n / freeze_divisor, freeze_max))
    // trucks at n trucks, not recomputed from the cloud for every truck. The tables of a frozen
    // span depend only on the frozen options and their own record, so an offline replay builds
    // them all at once, one truck per thread (prebuild), with the same bits as one at a time:
    // 2 threads building one truck together reach 1.6x, one truck each 1.95x (measured, AS1).
    // Below n = 2 freeze_divisor every truck refreezes, as before; after that the options lag the
    // cloud by at most 1/freeze_divisor of the trucks, well inside population_widening.
    int freeze_divisor = 32;
    int freeze_max = 64;
    // The processes the fit runs on (util/ranks.hpp; null: this one alone). Every rank holds the
    // same particles; truck i's table is built and kept by rank i % R alone, which sums its own
    // trucks' ℓ_i for every particle, and the exact partial sums are added over the ranks, so a
    // seed gives the same bits for any R. The newest truck's table goes to every rank, and each
    // computes its ℓ for a slice of the particles. The ranks must call every member in the same order.
    const util::Ranks* ranks = nullptr;
    // Where the absorbed trucks' tables live: "" in memory; a directory, in an unnamed file there
    // that the kernel pages (model/table_store.hpp), so the process's own memory stays flat as the
    // trucks grow (a stream puts them in its state directory). The same bits either way.
    std::string table_spill_directory;
    // A model extension fitted alongside θ (not owned; outlives the target), or null for the base
    // model. Its parameters ψ join each particle (the moves see (θ, ψ) as one block). Two kinds fit
    // here: one that changes the fleet's stiffness distribution alone (edits_forward() false), whose
    // mixture reweights the lattice's nodes exactly (FleetMarginal::prepare); and a one-parameter
    // effect inside the dynamics (carried_by_psi_window()), whose ψ is interpolated between tables at
    // the nodes of a window that follows its posterior (marginal_psi_window.hpp). UsageError for any
    // other (a discrete choice, an added profile, several effects): those need the latent core.
    const ModelExtension* extension = nullptr;
    // The ψ window of an effect inside the dynamics: its nodes and how it follows the posterior.
    PsiWindowSettings psi_window;
  };

  struct TableSettings {
    model::Lattice lattice;
    double sigma_ref = 0.0;
    std::optional<model::TruckTableOptions::Population> population;
    // With an effect carried by a ψ window: the window (in ψ) and its number of nodes Q.
    std::optional<model::PsiWindow> window;
    int window_nodes = 0;
  };

  MarginalTarget(const site::Site& site, Options options) : MarginalTarget(std::vector<const site::Site*>{&site}, std::move(options)) {}
  // One fleet over several sites (docs/sites.md): each truck's table is built through its own
  // site (add_truck's `site`, an index into `sites`), θ is shared. The sites must outlive this.
  MarginalTarget(std::vector<const site::Site*> sites, Options options);

  // θ of every particle from the prior (before the first truck).
  void initialise(const smc::RngFactory& rngs);

  // Builds the truck's table with the settings the current cloud implies (W: the engine's normalised
  // weights) and makes its ℓ the next stage's increment. DataError-free: the record was checked.
  // A table prebuilt for this truck under the options still frozen is taken instead of building one.
  // `site`: which of the sites logged the truck (UsageError if out of range).
  void add_truck(double speed_mps, double sprung_mass_kg, const Eigen::VectorXd& impact_factors,
                 const Eigen::ArrayXd& W, const smc::ParallelFor& parallel, std::uint32_t site = 0);

  // One upcoming truck's data, for prebuild().
  struct UpcomingTruck {
    double speed_mps = 0.0, sprung_mass_kg = 0.0;
    const Eigen::VectorXd* impact_factors = nullptr;
    std::uint32_t site = 0;
  };
  // Builds the fits and tables of the next trucks (upcoming[0] is the next add_truck's), as many as
  // the frozen options still cover (freezing them now from W if they are due, exactly as the next
  // add_truck would), one truck per thread. add_truck() then takes them: the same bits as without.
  // Nothing before the first truck (its table sets the lattice). Returns how many were built.
  std::size_t prebuild(const std::vector<UpcomingTruck>& upcoming, const Eigen::ArrayXd& W,
                       const smc::ParallelFor& parallel);
  // How many upcoming trucks a prebuild() now would build at most (0 before the first truck).
  std::size_t prebuild_span() const;

  // Why the tables should be rebuilt now, or "" (see the header).
  std::string rebuild_reason(const Eigen::ArrayXd& W) const;
  // Rebuilds every table with the settings the cloud implies; the next stage is the correction.
  void begin_rebuild(const Eigen::ArrayXd& W, const smc::ParallelFor& parallel);
  // After every stage: folds the stage's increment into log γ (the target becomes idle).
  void finish_stage();

  Eigen::Index trucks() const { return static_cast<Eigen::Index>(absorbed_.size()); }
  const Eigen::MatrixXd& theta() const { return theta_; }  // 7 x P
  const Eigen::MatrixXd& psi() const { return psi_; }      // the extension's ψ, dim x P (0 rows without)
  const ModelExtension* extension() const { return options_.extension; }
  const TableSettings& settings() const { return settings_; }
  // The tables of this rank's trucks, in truck order (every truck's with one rank): with a ψ window,
  // those at its middle node (a proposal near the posterior for latent draws; the likelihood
  // interpolates over every node's, node_tables()).
  const model::TableStore& tables() const { return stores_[stores_.size() / 2]; }
  const std::vector<model::TableStore>& node_tables() const { return stores_; }
  // The ψ window's nodes (null without one).
  const model::PsiGrid* psi_grid() const { return grid_ ? &*grid_ : nullptr; }
  const util::Ranks& ranks() const { return *ranks_; }
  // The tables' own check of their z approximation (TruckTable::lateral_error_nats) over the trucks
  // absorbed by this process since the second, on every rank (not kept in checkpoints: a
  // diagnostic): the mean of its absolute value, in nats per truck (NaN before any check).
  double lateral_error_mean() const {
    return lateral_checked_ > 0 ? lateral_error_abs_sum_ / static_cast<double>(lateral_checked_)
                                : std::numeric_limits<double>::quiet_NaN();
  }
  long lateral_checked() const { return lateral_checked_; }
  const model::FleetMarginal& marginal() const { return marginal_; }
  // Every truck's data and fit, in truck order (its site indexes sites()).
  const AbsorbedTrucks& absorbed() const { return absorbed_; }
  const std::vector<const site::Site*>& sites() const { return sites_; }
  // Integrator passes spent on this rank's tables (all of them with one rank).
  long long integrator_passes() const { return passes_; }
  // Trucks whose table add_truck() took from a prebuild() (by this process: not in checkpoints).
  long prebuilt_used() const { return prebuilt_used_; }
  int rebuilds() const { return rebuilds_; }
  // Wall seconds this rank spent building trucks' fits and tables (arrivals, prebuilds, rebuilds)
  // in this process (not kept in checkpoints: for the scaling figures of docs/sites.md).
  double table_seconds() const { return table_seconds_; }
  // The state was read from a format whose truck records differ from this build's (before version 5:
  // no site before 3, no z-moment slopes before 5): the records this build appends would not match
  // the log's, so the whole log must be written anew.
  bool read_old_truck_records() const { return loaded_version_ != 0 && loaded_version_ < 5; }
  // Σ_i ℓ_i(θ) + log p(θ) of particle p as cached (for tests: the density the moves target).
  double cached_log_posterior(Eigen::Index p) const { return base_sum_[p] + inc_[p] + log_prior(p); }
  // The same recomputed from the tables (collective: every rank calls it); psi: the extension's
  // parameters (ignored without one).
  double log_posterior(const HyperVector& theta, const double* psi = nullptr) const;
  // What ℓ_i needs of (θ, ψ) on a FleetMarginal of this target (the extension's stiffness mixture
  // tabulated over the k indices its tables use; psi null: the base model's).
  model::ThetaTerms terms_for(const model::FleetMarginal& marginal, const HyperVector& theta, const double* psi) const;

  // Checkpoint: the particles, the data and the tables (so a resume does not rebuild them).
  void save(BinaryWriter& out) const;
  void load(BinaryReader& in);
  // The same in two parts, so that a stream's checkpoint per truck costs O(1): the particles and
  // settings (fixed size), and the trucks (data, fit and table of each) in [begin, end), which a
  // stream appends to a log; load_trucks() reads `count` such records after load_particles().
  void save_particles(BinaryWriter& out) const;
  void save_trucks(BinaryWriter& out, std::size_t begin, std::size_t end) const;
  // Returns the number of trucks the particles belong to (load that many with load_trucks).
  std::uint64_t load_particles(BinaryReader& in);
  void load_trucks(BinaryReader& in, std::uint64_t count);

  // smc::TemperedModel
  Eigen::Index particles() const override { return options_.particles; }
  void log_density(Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                   const smc::ParallelFor& parallel) override;
  std::vector<smc::BlockSpec> blocks() const override {
    return {{psi_.rows() > 0 ? "theta+psi" : "theta", kHyperCount + psi_.rows()}};
  }
  void get_block(int block, Eigen::Ref<Eigen::MatrixXd> values) const override;
  void log_density_at(int block, const Eigen::Ref<const Eigen::MatrixXd>& proposed,
                      Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                      const smc::ParallelFor& parallel) override;
  void accept(int block, const std::vector<char>& accepted, const Eigen::Ref<const Eigen::MatrixXd>& proposed) override;
  void resample(const std::vector<Eigen::Index>& ancestors) override;
  // With an extension that has a stiffness jump (e.g. two classes trading places): "stiffness jump".
  std::vector<std::string> model_moves() const override;
  ModelMoveResult run_model_move(int move, int run_in_stage, double phi, const smc::RngFactory& rngs,
                                 const smc::ParallelFor& parallel, Eigen::Ref<Eigen::ArrayXd> log_base,
                                 Eigen::Ref<Eigen::ArrayXd> loglik) override;

 private:
  enum class Mode { kIdle, kTruck, kCorrection };
  // A rebuild builds this many tables at a time (about 5 MB of them on AS1's 16 sensors).
  static constexpr Eigen::Index kRebuildBatch = 1024;
  HyperVector theta_of(Eigen::Index p) const;
  const double* psi_of(Eigen::Index p) const { return psi_.rows() > 0 ? psi_.col(p).data() : nullptr; }
  Eigen::Index psi_dim() const { return psi_.rows(); }
  // The moves' coordinates (θ's scales on the log scale, ψ in the extension's move coordinates)
  // and back, with the log Jacobian of the map (the target's density in move coordinates gains it).
  void encode(const HyperVector& theta, const double* psi, double* x) const;
  void decode(const double* x, HyperVector& theta, double* psi) const;
  double log_jacobian(const HyperVector& theta, const double* psi) const;
  double log_prior_of(const HyperVector& theta, const double* psi) const;
  // The k indices of the tables in stores_ (and newest_), and of old_stores_ during a correction:
  // the range terms_for() tabulates an extension's stiffness mixture over.
  void note_k_range(const model::TruckTable& table, int& lo, int& hi) const;
  int k_lo_ = 0, k_hi_ = -1, old_k_lo_ = 0, old_k_hi_ = -1;
  // The table option max_piece_sd_m the cloud implies (Options::lateral_piece_fraction).
  double max_piece_sd(const Eigen::ArrayXd& W) const;
  double log_prior(Eigen::Index p) const { return log_prior_of(theta_of(p), psi_of(p)); }
  // Σ_i ℓ_i(θ, ψ) over every rank's trucks in a set of node stores (collective).
  double sum_loglik(const std::vector<model::TableStore>& stores, const model::PsiGrid* grid,
                    const model::FleetMarginal& marginal, const HyperVector& theta, const double* psi) const;
  // Adds each of `count` particles' Σ_{i<end} ℓ_i at every node of `stores` to out[q * stride + c].
  static void add_node_sums(const std::vector<model::TableStore>& stores, const model::FleetMarginal& marginal,
                            std::size_t end, const model::ThetaTerms* terms, std::size_t count, util::ExactSum* out,
                            std::size_t stride);
  // Σ over the nodes of a truck's or a sum's values at ψ (the only value without a window).
  double combine(const model::PsiGrid* grid, const double* psi, const util::ExactSum* sums, std::size_t stride) const {
    return grid == nullptr ? sums[0].value() : interpolate_node_sums(*grid, psi[0], sums, stride);
  }
  // A truck's tables at every node of settings' window (one table, the base model's, without one),
  // each node's fit made under its ψ; `fit` is the truck's fit without a window (reused), and with
  // one it receives the middle node's. Serial: callers parallelise over trucks.
  std::vector<model::TruckTable> build_tables(std::uint32_t site, double speed_mps, double sprung_mass_kg,
                                              const Eigen::VectorXd& impact_factors, const TableSettings& settings,
                                              const model::TruckTableOptions& options, model::TruckFit& fit,
                                              bool fit_given) const;
  // The window settings imply ([lo, hi] and Q); stores and grid sized to it.
  void set_window(const model::PsiWindow& window);
  std::vector<model::TableStore> empty_stores() const;
  // The prior box of ψ (the carried effect's one parameter).
  double box_lo() const { return options_.extension->parameters()[0].lo; }
  double box_hi() const { return options_.extension->parameters()[0].hi; }
  bool windowed() const { return grid_.has_value(); }
  // Whether the ψ window must be rebuilt now (check_psi_window and the rebuilds' spacing), and why.
  bool window_due(const Eigen::ArrayXd& W, std::string* why) const;
  // The newest truck's ℓ at (θ, ψ) from its tables in newest_.
  double newest_loglik(const model::ThetaTerms& terms, const double* psi) const;
  // The fleet's stiffness distribution per particle, as the tables' settings need it: its mean and
  // sd (the predictive that decides which nodes a table keeps), and the narrowest sd among its
  // components that carry at least kResolvedComponentWeight of the trucks (what the lattice must
  // resolve). σ_k and K for the base model; an extension's mixture otherwise.
  struct StiffnessMoments {
    Eigen::ArrayXd mean, sd;
    Eigen::RowVectorXd narrowest_sd;
  };
  static constexpr double kResolvedComponentWeight = 0.05;
  StiffnessMoments stiffness_moments() const;
  // The settings the cloud implies.
  TableSettings ideal_settings(const Eigen::ArrayXd& W) const;
  model::TruckTableOptions table_options(const TableSettings& s) const;
  // The options a new truck's table is built with: the frozen ones, frozen anew from W when due.
  const model::TruckTableOptions& frozen_table_options(const Eigen::ArrayXd& W);
  std::int64_t freeze_span(std::int64_t n) const;

  // The FleetMarginal of these sites on a lattice.
  model::FleetMarginal make_marginal(const model::Lattice& lattice) const;
  const site::Site& site_of(std::uint32_t s) const { return *sites_[s]; }
  // UsageError unless `site` indexes sites_ and the impact factors fit its sensors.
  void check_truck(std::uint32_t site, const Eigen::VectorXd& impact_factors) const;

  std::vector<const site::Site*> sites_;
  Options options_;
  const util::Ranks* ranks_;
  long lateral_checked_ = 0;
  double lateral_error_abs_sum_ = 0.0;
  TableSettings settings_;
  model::FleetMarginal marginal_;
  // One store per node of the ψ window (one without a window), each with every truck of this rank.
  std::vector<model::TableStore> stores_;
  std::optional<model::PsiGrid> grid_;
  // The newest truck's tables, on every rank (its rank sends them): in a truck stage each rank
  // computes that truck's ℓ for its slice of the particles (util::Ranks::slice), so the stage's one
  // serial piece of work is shared too.
  std::vector<model::TableStore> newest_;
  // During a correction stage: the tables, window and settings being replaced.
  std::optional<std::vector<model::TableStore>> old_stores_;
  std::optional<model::PsiGrid> old_grid_;
  std::optional<model::FleetMarginal> old_marginal_;
  Mode mode_ = Mode::kIdle;

  // Every truck's data and fit, on every rank (the lattice follows the fits' widths; a rebuild
  // reads the data of the rank's own trucks); the tables in stores_ are this rank's trucks' only.
  AbsorbedTrucks absorbed_;
  // Σ_i log of each fit's likelihood sd per unit σ (k and k_t), in truck order: the geometric mean
  // that sets the lattice spacing, kept as it grows so the per-truck settings cost O(1), not O(n).
  double sum_log_sd_k_ = 0.0, sum_log_sd_kt_ = 0.0;
  void add_to_width_sums(const model::TruckFit& f) {
    sum_log_sd_k_ += std::log(f.stiffness_sd_per_sigma);
    sum_log_sd_kt_ += std::log(f.tyre_stiffness_sd_per_sigma);
  }

  Eigen::MatrixXd theta_;   // 7 x P
  Eigen::MatrixXd psi_;     // the extension's ψ: dim x P (no rows without one)
  Eigen::ArrayXd base_sum_;  // Σ ℓ_i over the trucks in log γ
  Eigen::ArrayXd inc_;       // the stage's increment at the current θ
  Eigen::ArrayXd proposed_base_sum_, proposed_inc_;
  long long passes_ = 0;
  int rebuilds_ = 0;
  Eigen::Index trucks_at_last_rebuild_ = 0;
  // The predictive (k, k_t) at the last rebuild, for the drift rule.
  std::optional<model::TruckTableOptions::Population> population_at_rebuild_;
  // New trucks' table options, frozen until trucks() reaches frozen_until_ (Options::freeze_divisor);
  // unset before the second truck and after a rebuild. Part of the checkpoint.
  std::optional<model::TruckTableOptions> frozen_;
  std::int64_t frozen_until_ = 0;
  // Prebuilt fits and tables for the trucks after trucks() (a cache, not state: a resume rebuilds
  // them), valid while the options they were built with are frozen (freeze_id_).
  struct Prebuilt {
    std::int64_t truck = 0;
    std::uint64_t freeze_id = 0;
    std::uint32_t site = 0;
    model::TruckFit fit;
    std::vector<model::TruckTable> tables;  // one per node
  };
  std::vector<Prebuilt> prebuilt_;  // this rank's trucks of the span [prebuilt_from_, prebuilt_until_)
  std::int64_t prebuilt_from_ = 0, prebuilt_until_ = 0;
  std::uint64_t freeze_id_ = 0;
  // The format version of the state load_particles() read (truck records before 3 name no site).
  std::uint32_t loaded_version_ = 0;
  long prebuilt_used_ = 0;
  double table_seconds_ = 0.0;
};

}  // namespace ssrfleet::fleet
