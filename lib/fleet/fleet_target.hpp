// The fleet model (fleet_model.hpp) presented to the generic tempered SMC engine as a target.
// This is the only place where the fleet meets particles: the engine never sees a truck, the
// densities never see a particle.
//
// Each particle holds θ (7 hyperparameters) and the latents (k, k_t, z) of every truck absorbed
// so far, with each truck's sum of squared residuals cached so θ moves need no integrator call.
// When truck n+1 arrives (add_truck), every particle is extended with latents drawn from
// p(x | θ) (or from the truck's table in a marginal fit, Options::proposals), so the stage's
// incremental weight is the new truck's likelihood alone; the engine
// tempers it in. The engine's random-walk MH block is the new truck's latents; the model's own
// moves (model_moves; FleetSmc's schedule says when each runs) are θ by Gibbs and exact
// independence MH, and, once the new truck is fully in (φ = 1), a few random-walk MH sweeps over
// every older truck's latents, all trucks and particles in one batched integrator call: the trucks are conditionally independent given θ, so this is one
// Metropolis-within-Gibbs sweep per particle, and it keeps older trucks' paths from collapsing
// onto a few ancestors (path degeneracy) at a cost of n passes per particle per truck.
//
// Stage base density (log γ, docs/inference.md):
//   log p(θ) + Σ_{i≤n} [log p(x_i | θ) + log p(y_i | x_i, σ_IF)] + log p(x_{n+1} | θ)
// computed in O(1) per particle from running sums (Σk, Σk², Σk_t, Σk_t², Σz, Σz², ΣSSR), or, with
// an extension's stiffness distribution (which has no sufficient statistic), in O(n) for the k part.
// The densities come from model/fleet_conditionals.hpp and, for what an extension changes,
// model/extension_conditionals.hpp: the batch MCMC calls the same ones.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "fleet/new_truck_proposals.hpp"
#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"
#include "smc/target.hpp"
#include "util/binary_io.hpp"

namespace ssrfleet::fleet {

class FleetTarget final : public smc::TemperedModel {
 public:
  struct Options {
    Eigen::Index particles = 1024;
    PriorBounds prior;
    // An optional model extension (docs/model.md): its parameters ψ join θ in every particle,
    // drawn from their prior before the first truck, and move by the model moves "extension jump"
    // (the extension's own jump between distant modes, ModelExtension::jump, if it has one) and
    // "extension random walk", each sweep re-simulating every kept truck (n passes per particle).
    // An extension that replaces the fleet's stiffness distribution (second_class) changes the
    // density of every truck's k instead, and (K, σ_k, ψ) move by "stiffness distribution", a
    // random walk on their conditional, with no integrator call. Not owned; must outlive the
    // target.
    const ModelExtension* extension = nullptr;
    // Optional: where a new truck's latents are drawn from instead of p(x | θ) (new_truck_proposals.hpp
    // says why). Each particle draws `proposal_draws` latents x_1..x_m from the defensive mixture
    //   q(x) = (1 - defensive_share) q_table(x | θ) + defensive_share p(x | θ, ψ)
    // (Hesterberg 1995: a weight w_j = p(x_j | θ, ψ) p(y | x_j, ψ) / q(x_j) is then at most
    // p(y | x_j) / defensive_share, however poorly the table, built for the base model, fits the
    // particle's ψ). Its stage increment is the estimate Ẑ = (1/m) Σ_j w_j of the truck's marginal
    // likelihood, and it keeps x_k with k drawn ∝ w_k. This is importance sampling on an extended
    // space (θ, ψ, x_{1..m}, k) whose target at φ = 1 has the exact posterior as its (θ, ψ, x_k)
    // marginal, and x_{j≠k} as ancillaries drawn from q given the stage's starting θ (Andrieu & Roberts
    // 2009; Naesseth, Lindsten & Schön 2015): more draws, a less noisy Ẑ, a better evidence. Below
    // φ = 1 that extended target is not the one the moves keep, so nothing moves there ("theta"
    // and "stiffness distribution" report that they did not run, and the stage has no random-walk
    // block: the newest truck moves with the older ones from the next stage on). Not owned; must
    // outlive the target.
    const NewTruckProposals* proposals = nullptr;
    double defensive_share = 0.1;
    int proposal_draws = 16;
    // With proposals, the moves run after every stage (not only after resampling) while at most this
    // many trucks are in: ψ is still being located then, and a stage without moves leaves its cloud
    // short of the regions the next trucks favour (on a 5 % gain of one sensor, moving only after
    // resampling lost 30 to 70 nats of evidence over the first 20 trucks against moving every stage).
    // The moves of those stages cost little: n is small.
    int every_stage_moves_until = 25;
  };

  FleetTarget(const site::Site& site, Options options);

  // Draws θ for every particle from the prior (before the first truck).
  void initialise(const smc::RngFactory& rngs);
  // Extends every particle with the truck's latents drawn from p(x | θ) and makes its
  // likelihood the increment of the next stage. The record's sensor count must match the site.
  void add_truck(const records::WimRecord& record, const smc::RngFactory& rngs, const smc::ParallelFor& parallel);

  Eigen::Index trucks() const { return kept_trucks(); }              // absorbed so far
  Eigen::Index kept_trucks() const { return static_cast<Eigen::Index>(speed_mps_.size()); }  // every one keeps its latents
  const Eigen::MatrixXd& theta() const { return theta_; }  // 7 x P
  const Eigen::MatrixXd& psi() const { return psi_; }      // extension parameters: dim x P (0 rows without one)
  const ModelExtension* extension() const { return options_.extension; }
  // The data of every truck absorbed, oldest first.
  const std::vector<double>& kept_speed_mps() const { return speed_mps_; }
  const std::vector<double>& kept_sprung_mass_kg() const { return sprung_mass_kg_; }
  const std::vector<Eigen::VectorXd>& kept_observed_if() const { return observed_if_; }
  // Latents of kept truck j (0 = the oldest kept) for every particle: 3 x P (k, k_t, z).
  Eigen::MatrixXd truck_latents(Eigen::Index truck) const;
  // Every kept truck's latents: 3n x P, rows 3j..3j+2 = (k, k_t, z) of kept truck j.
  const Eigen::MatrixXd& latents() const { return latents_; }
  const Eigen::MatrixXd& sums_of_squared_residuals() const { return ssr_; }  // trucks x P
  // Observed speeds and sprung masses for predictions: every truck's.
  std::pair<std::vector<double>, std::vector<double>> observed_speeds_and_masses() const {
    return {speed_mps_, sprung_mass_kg_};
  }
  long long integrator_passes() const { return passes_; }
  double older_acceptance() const { return older_acceptance_; }
  double extension_acceptance() const { return extension_acceptance_; }
  double stiffness_acceptance() const { return stiffness_acceptance_; }
  double extension_jump_acceptance() const { return extension_jump_acceptance_; }    // of the last jump sweep
  double interweave_acceptance() const { return interweave_acceptance_; }  // of the last interweave

  // Checkpoint: the particles and the data absorbed, exactly (binary_io.hpp). load() expects a
  // target built with the same site and options; DataError if the saved one does not fit.
  void save(BinaryWriter& out) const;
  void load(BinaryReader& in);

  // smc::TemperedModel
  Eigen::Index particles() const override { return options_.particles; }
  void log_density(Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                   const smc::ParallelFor& parallel) override;
  std::vector<smc::BlockSpec> blocks() const override;
  void get_block(int block, Eigen::Ref<Eigen::MatrixXd> values) const override;
  void log_density_at(int block, const Eigen::Ref<const Eigen::MatrixXd>& proposed,
                      Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                      const smc::ParallelFor& parallel) override;
  void accept(int block, const std::vector<char>& accepted,
              const Eigen::Ref<const Eigen::MatrixXd>& proposed) override;
  bool moves_every_step() const override {
    return newest_from_proposals_ && kept_trucks() <= options_.every_stage_moves_until;
  }
  void resample(const std::vector<Eigen::Index>& ancestors) override;
  // The model moves, by name (in model_moves() order):
  //   "older trucks"            one MH sweep over every older kept truck's latents (φ = 1 only in
  //                             FleetSmc's schedule), a random walk on (k, k_t, z) on even runs of a
  //                             stage and an independence proposal of (k, k_t) from p(· | θ) on odd;
  //   "extension jump"          ψ by the extension's jump (with an extension that has one);
  //   "extension random walk"   ψ by a random walk scaled on the cloud;
  //   "stiffness distribution"  (K, σ_k, ψ) of an extension's stiffness distribution;
  //   "tyre stiffness interweave" (K_t, σ_kt) with every truck's standardised tyre stiffness
  //                             (k_t - K_t) / σ_kt held fixed, so every k_t moves with them
  //                             (exact regime only; every kept truck re-simulated);
  //   "theta"                   θ given the latents: exact Gibbs draws of K, sigma_k, K_t, sigma_kt
  //                             and sigma_IF (their conditionals stay standard under the uniform
  //                             box, truncated_samplers.hpp), and for Z and sigma_z an independence
  //                             MH whose proposal is their conditional without the road truncation.
  // A move with nothing to do (no older truck yet, no extension) reports that it did not run.
  static constexpr std::string_view kOlderTrucksMove = "older trucks";
  static constexpr std::string_view kExtensionJumpMove = "extension jump";
  static constexpr std::string_view kExtensionWalkMove = "extension random walk";
  static constexpr std::string_view kStiffnessMove = "stiffness distribution";
  static constexpr std::string_view kInterweaveMove = "tyre stiffness interweave";
  static constexpr std::string_view kThetaMove = "theta";
  std::vector<std::string> model_moves() const override;
  ModelMoveResult run_model_move(int move, int run_in_stage, double phi, const smc::RngFactory& rngs,
                                 const smc::ParallelFor& parallel, Eigen::Ref<Eigen::ArrayXd> log_base,
                                 Eigen::Ref<Eigen::ArrayXd> loglik) override;

  // Rejuvenation at the end of a replay: `sweeps` Metropolis-within-Gibbs sweeps at φ = 1 over
  // every kept truck's latents (the newest included), alternating the random walk and the
  // independence proposal from p(k, k_t | θ) as the stages do, then ψ, the tyre-stiffness
  // interweave and θ as the model moves do. Each sweep costs 2n passes per particle (3n with an
  // extension that edits the forward model). It leaves the posterior and the weights as they are
  // and only undoes the ancestry the particles share: the stages refresh older trucks twice per
  // truck, so after the last few resamplings many particles still carry the same latents for
  // most trucks, and σ_k, K_t and σ_kt, which only those latents inform, vary from seed to seed.
  void rejuvenate(int sweeps, const smc::RngFactory& rngs, const smc::ParallelFor& parallel);

 private:
  // Running sums over every truck before the newest, per particle.
  enum Sum : int { kSumK = 0, kSumK2, kSumKt, kSumKt2, kSumZ, kSumZ2, kSumSsr, kSumCount };

  // log γ of particle i at θ with the newest truck's latents at newest_latents.
  double base_density(Eigen::Index i, const HyperVector& theta, const double* newest_latents) const;
  // log p(θ) + the older trucks' terms of log γ (everything but the newest truck).
  double older_density(Eigen::Index i, const HyperVector& theta) const;
  // A truck's latents drawn from p(x | θ, ψ) of particle i, z truncated to the road, into x[0..2].
  void prior_latents(Eigen::Index i, smc::Rng& rng, double* x) const;
  // add_truck's draw with Options::proposals: m draws per particle, the chosen one kept, Ẑ in
  // newest_log_zhat_.
  void draw_newest_from_proposals(const records::WimRecord& record, const smc::RngFactory& rngs,
                                  const smc::ParallelFor& parallel);
  // log p(k, k_t, z | θ, ψ) of one truck, with the extension's stiffness distribution if it has one.
  double latent_log_density(const double* latents, const HyperVector& theta, const double* psi) const;
  // A truck's k drawn from the fleet distribution p(k | θ, ψ): the base model's N(K, σ_k²) or the
  // extension's.
  double draw_stiffness(smc::Rng& rng, const HyperVector& theta, const double* psi) const;
  // Whether the extension replaces the fleet's stiffness distribution (model_extension.hpp).
  bool stiffness_edited() const;
  // Σ over particle i's first `trucks` kept trucks of the extension's log p(k | mean, sd, ψ).
  double stiffness_log_density(Eigen::Index i, double mean, double sd, const double* psi, Eigen::Index trucks) const;
  double newest_loglik(double ssr, double sigma_if) const;
  void recompute_sums(Eigen::Index particle);
  // One simulation: a truck at some latents (k, k_t, z); its SSR goes to *ssr_out.
  struct SsrJob {
    Eigen::Index truck;
    const double* latents;
    double* ssr_out;
    const double* psi = nullptr;  // the particle's extension parameters (with an extension)
  };
  // Runs the jobs through one batched integrator call (serial: callers split the work).
  // Non-physical latents (k or k_t <= 0, z off the road) get an infinite SSR, unsimulated.
  void simulate_ssr(const std::vector<SsrJob>& jobs) const;
  // SSR of every kept truck (n x P) at the latents `latents` (3n x P) and extension parameters
  // `psi` (d x P), for the particles marked in `inside` (+inf for the others), in one batched
  // integrator call per chunk of particles; counts the passes.
  Eigen::MatrixXd every_kept_truck_ssr(const Eigen::MatrixXd& latents, const Eigen::MatrixXd& psi,
                                       const std::vector<char>& inside, const smc::ParallelFor& parallel);
  // SSR of truck `truck` at the latents in columns of `latents` (3 x P) for every particle.
  void residuals(Eigen::Index truck, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                 Eigen::Ref<Eigen::ArrayXd> ssr_out, const smc::ParallelFor& parallel);
  HyperVector theta_of(Eigen::Index particle) const;
  // One MH sweep over every older truck's latents of every particle, at φ = 1: a random walk on
  // (k, k_t, z), or (stiffness_from_prior) an independence proposal of (k, k_t) from p(· | θ).
  // Sweeps the oldest `swept` kept trucks (all but the newest in a stage, all of them in
  // rejuvenate); scales[j] is truck j's adapted proposal multiplier, updated here.
  void older_trucks_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel, bool stiffness_from_prior,
                          Eigen::Index swept, std::vector<double>& scales);
  // θ given the latents (the Gibbs and independence MH draws of the "theta" move), at temperature φ
  // for the newest truck's likelihood; writes every particle's log γ and ℓ.
  void theta_moves(double phi, const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                   Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik);
  // One MH sweep over ψ of every particle at φ = 1 (every kept truck re-simulated): a random
  // walk scaled on the cloud, or the extension's jump.
  enum class PsiMove { kRandomWalk, kJump };
  void extension_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel, PsiMove move);
  // With an extension's stiffness distribution (K, σ_k) have no standard conditional: they move,
  // with ψ when ψ does not touch the forward model, by kStiffnessSteps random-walk MH steps per
  // call on their conditional given every kept truck's k (no integrator call). False when it did
  // not run (no truck, or every particle the same point: nothing to scale a walk on).
  bool stiffness_distribution_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel);
  static constexpr int kStiffnessSteps = 3;
  // One ancillary (non-centred) MH step per particle on (K_t, σ_kt), Yu & Meng's interweaving as
  // the batch MCMC does it (batch_mcmc_interweave.hpp has the derivation): a random walk in
  // (K_t, log σ_kt) scaled on the cloud, every truck's k_t = K_t + σ_kt ε with ε held fixed, the
  // ratio the likelihood ratio over every kept truck (the newest at power φ) times σ_kt'/σ_kt.
  // The centred Gibbs draw of "theta" cannot leave the funnel where every k_t sits at K_t and
  // σ_kt is small (speed_bias, whose factor trades against K_t, showed it: one SMC seed kept 10 %
  // of its weight there, the MCMC 0.8 %). Writes log γ and ℓ of every particle that moved.
  // Does nothing when every particle is the same point (K_t, σ_kt): false then.
  bool tyre_stiffness_interweave(double phi, const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                                 Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik);

  const site::Site& site_;
  Options options_;
  LateralRange lateral_;
  int sensors_ = 0;
  // log p(θ) anywhere inside the prior box (PriorBounds::log_prior's sum of logs, computed once).
  double log_prior_inside_ = 0.0;

  // Observed data per kept truck.
  std::vector<double> speed_mps_, sprung_mass_kg_;
  std::vector<Eigen::VectorXd> observed_if_;
  // Particle states.
  Eigen::MatrixXd theta_;    // 7 x P
  Eigen::MatrixXd psi_;      // extension parameters, dim x P
  Eigen::MatrixXd latents_;  // 3n x P: rows 3j..3j+2 = (k, k_t, z) of truck j
  Eigen::MatrixXd ssr_;      // n x P: sum of squared residuals of truck j
  Eigen::MatrixXd sums_;     // kSumCount x P (trucks before the newest)
  Eigen::ArrayXd proposed_ssr_;       // SSR at the last proposals of the newest truck's block
  std::vector<double> older_scale_;   // per older truck: adapted proposal multiplier
  // Whether the newest truck came from Options::proposals (until the next add_truck or load), and
  // then each particle's log Ẑ, the stage's increment.
  bool newest_from_proposals_ = false;
  Eigen::ArrayXd newest_log_zhat_;
  double older_acceptance_ = 0.0;     // of the last older-trucks sweep
  double extension_scale_ = 1.0;      // adapted proposal multiplier of the ψ random walk
  double extension_acceptance_ = 0.0; // of the last ψ sweep
  double stiffness_scale_ = 1.0;      // adapted proposal multiplier of the (K, σ_k, ψ) random walk
  double stiffness_acceptance_ = 0.0; // of the last such sweep
  double extension_jump_acceptance_ = 0.0;  // of the last jump sweep
  double interweave_scale_ = 1.0;       // adapted proposal multiplier of the (K_t, log σ_kt) walk
  double interweave_acceptance_ = 0.0;  // of the last interweave
  long long passes_ = 0;
};

}  // namespace ssrfleet::fleet
