// The paper's batch MCMC (Wilson, Harris & O'Brien §3.2): Metropolis-within-Gibbs over all
// 3N + 7 unknowns of the fleet model (fleet_model.hpp), the baseline that the sequential
// sampler is checked and benchmarked against (docs/inference.md).
//
// One sweep:
//  1. Latents. Given theta the trucks are conditionally independent, so every truck proposes a
//     random-walk move of (k, kt, z) at once, all proposals go through ONE batched quarter-car
//     call (Site::impact_factors), and each truck accepts or rejects on its own. A proposal
//     with k <= 0, kt <= 0 or z off the road has target density 0 and is rejected without
//     being simulated. Each truck's proposal covariance (its chain's covariance, scaled) and
//     scale are adapted during burn-in towards `target_acceptance`, then frozen, so the chain
//     after burn-in is a time-homogeneous Metropolis-within-Gibbs chain and valid.
//  2. K, K_t: exact Gibbs, N(mean of latents, sigma^2 / N) truncated to the prior box.
//  3. sigma_k, sigma_kt, sigma_IF: exact Gibbs. With the prior uniform on sigma, the precision
//     has a truncated Gamma((n-1)/2, S/2) conditional (truncated_samplers.hpp); for sigma_IF,
//     n = N M and S is the total of the per-truck sums of squared residuals, cached from step 1
//     so no integrator call is needed. With n < 2 the shape is not positive: random-walk MH.
//  4. (Z, sigma_z): the truncation of z_n to the road makes the normaliser depend on both, so
//     there is no conjugate form: `z_moves_per_sweep` joint random-walk MH steps (cheap, O(N)).
//  5. With a model extension (`extension`, model_extension.hpp; docs/model.md), its parameters ψ
//     (uniform on their box) join the chain, and every simulated pass goes through the extended
//     forward model the latent SMC core uses (model/extended_forward.hpp). Each sweep after the
//     θ steps: if the extension has a jump between distant modes (ModelExtension::jump), one
//     jump every `psi_jump_every` sweeps; then `psi_moves_per_sweep` random-walk MH steps on ψ
//     (proposal covariance and scale adapted in burn-in only, then frozen). A step of an extension
//     that edits the forward model re-simulates every truck (one batched call of N passes); one
//     that does not needs no simulation. An extension that replaces the stiffness distribution
//     (second_class) changes the density of every k: the latent step's acceptance uses it, and
//     (K, sigma_k) lose their Gibbs step (2. above) for `stiffness_moves_per_sweep` random-walk
//     MH steps on their conditional, ψ joining them when ψ does not edit the forward model (as
//     in the SMC target's "stiffness distribution" move). The densities are shared with the SMC
//     target (model/extension_conditionals.hpp). batch_mcmc_extension.hpp holds these steps.
//  Interweaving (`interweave`, batch_mcmc_interweave.hpp): after the centred update of a chosen
//  pair among (K, sigma_k), (K_t, sigma_kt), (Z, sigma_z) above, `ancillary_steps` MH steps of the
//  same pair with the standardised latents (x_n - mean) / sd held fixed instead of the latents
//  (ASIS, Yu & Meng 2011); each re-simulates every truck (one batched call of N passes). By
//  default only (K_t, sigma_kt), the slowest block (measurements at the option).
//
// Initialisation (none of it uses the truth; `init` below: each truck at its own best fit by
// default, which replaces the k, k_t and z of the grid search described next):
//  - k_n = K = geometric centre of the K prior box (~4.5e5 N/m), kt_n = K_t = geometric centre
//    of the K_t box (~1.6e6 N/m); sigma_k, sigma_kt = 20 % of those (a generic coefficient of
//    variation).
//  - z_n by a coarse grid search: every truck is simulated at z = lo, lo + step, ..., hi
//    (`init_grid_step_m`, default 0.1 m) with k, kt at the values above, in one batched call,
//    and starts at the z of least squared residual. The z-likelihood is multimodal (the road
//    changes across its width) and a random walk from a poor start gets trapped in a far mode.
//  - Z, sigma_z = mean and sd of those z_n (clipped to the box); sigma_IF = the rms residual at
//    the grid optimum (clipped).
//  - theta is held at these values for the first `hold_theta_sweeps` sweeps, so the latents
//    spread out under the data before sigma_k, sigma_kt see them (all latents start equal, and a
//    sigma drawn from a zero spread sits at the bottom of its box: the hierarchical funnel).
//
// Files: batch_mcmc.cpp (the sweep), batch_mcmc_start.cpp (initialisation), batch_mcmc_options.cpp
// (option checks, the log posterior), batch_mcmc_extension.cpp (ψ and an extension's stiffness
// distribution), batch_mcmc_interweave.cpp (ancillary steps), batch_mcmc_residuals.cpp (the
// batched forward model).
//
// Every random number comes from one Boost mt19937_64 seeded with `seed`, drawn on the calling
// thread in a fixed order: the same seed gives the same chain on every machine (for a given Boost
// version) and at every thread count. Without an extension no ψ step draws anything, so the chain is
// the one of ssrfleet before extensions entered it, bit for bit. Only the batched integrator calls, where the time goes, are
// split over `threads` threads (trucks are independent; the split is at the integrator's 16-truck
// block boundaries, and each truck's result does not depend on its batch). The library prints
// nothing: progress goes to a callback.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

// What the progress callback sees.
struct BatchMcmcProgress {
  int iteration = 0;   // sweeps done so far
  int iterations = 0;  // total sweeps planned
  bool burning_in = true;
  double latent_acceptance = 0.0;  // mean over trucks, since the last report
  double z_acceptance = 0.0;       // (Z, sigma_z) MH, since the last report
  double seconds = 0.0;            // wall time since the start
};

struct BatchMcmcOptions {
  int iterations = 20000;  // sweeps in all, burn-in included
  int burn_in = 5000;      // sweeps discarded (and the only ones that adapt proposals)
  int thin = 1;            // keep every thin-th sweep after burn-in
  std::uint64_t seed = 1;
  PriorBounds prior;

  double target_acceptance = 0.3;  // per-truck latent acceptance the burn-in adapts towards
  int z_moves_per_sweep = 10;      // (Z, sigma_z) random-walk MH steps per sweep
  // Where every truck's chain starts. kBestFit: at the truck's own best fit of (k, k_t, z) with
  // every lateral line of the road scanned (model/truck_table.hpp's fit_truck). kGrid (ssrfleet
  // 0.1): z by a grid search at generic k, k_t. The z-likelihood has several modes across the road
  // and a random walk does not cross between them, so a chain keeps the mode it starts in: from
  // the grid, 29 of 1,000 trucks (Table 1, AS1) sat in another mode than the best fit's, and
  // their excess SSR raised σ_IF's posterior mean by 1.2 posterior sd.
  enum class Init { kBestFit, kGrid };
  Init init = Init::kBestFit;
  double init_grid_step_m = 0.1;   // grid step of the initial z search (kGrid)
  int hold_theta_sweeps = 100;     // theta fixed for the first min(this, burn_in) sweeps
  // Over-dispersion of θ's start (0: the start above, exactly). With d > 0 the start's K, K_t and Z
  // move by 2d posterior-sd-like steps (the fleet sd / sqrt(N), times a standard normal) and the
  // four sds are multiplied by exp(0.5 d × a standard normal), all clipped to the prior box, from a
  // generator of their own seeded by `seed` (the chain's stream is untouched). Several chains
  // (batch_mcmc_chains.hpp) start this way so that R̂ can see a chain that has not forgotten its start.
  double start_dispersion = 0.0;

  // Progress: called every `progress_every` sweeps (0 = never) and after the last one.
  int progress_every = 0;
  std::function<void(const BatchMcmcProgress&)> progress;

  // For tests and restarts: start from these instead of the initialisation above.
  // initial_latents is trucks x 3 (k, kt, z) in the records' order.
  std::optional<HyperVector> initial_theta;
  std::optional<Eigen::MatrixXd> initial_latents;
  // For tests: never update the latents (the sampler then targets p(theta | latents, data)).
  // The ancillary steps move the latents too, so they are off when this is set.
  bool freeze_latents = false;

  // Interweaving of ancillary (non-centred) updates (batch_mcmc_interweave.hpp). On sweeps it
  // with it % ancillary_every == 0 (once theta is free), each interwoven block gets
  // `ancillary_steps` MH steps right after its centred update. Each step is one batched call of N
  // passes, as much as the whole latent step, so a block pays only where its centred step is the
  // bottleneck. Measured on the paper's 100-truck case (Table 1 fleet, AS1, sigma_IF 0.02, 3 chain
  // seeds, 45,000 kept sweeps): the slowest hyperparameter is sigma_kt (ESS ≈ 15 per 1000 sweeps
  // centred); interweaving (K_t, sigma_kt) alone lifts it to ≈ 45 per 1000 sweeps at 1.9x the cost
  // per sweep (1.6x the ESS per second of the slowest coordinate after burn-in; 1.8x at 1,000
  // trucks); adding (K, sigma_k) costs a third call for no gain in the slowest one (≈ 42 per 1000
  // at 2.8x), and (Z, sigma_z), whose lateral positions are pinned by their data (per-truck
  // sd ≈ 0.04 population sd), already mixes well centred (ESS ≈ 800 per 1000 sweeps); a second
  // step or every other sweep did no better per second. Hence the defaults. Burn-in sweeps cost
  // 1.9x too: with the same 5000-sweep burn-in, the time to ESS 400 on all 7 falls by ≈ 1.2x.
  bool interweave = true;
  bool interweave_stiffness = false;      // (K, sigma_k) with k
  bool interweave_tyre_stiffness = true;  // (K_t, sigma_kt) with kt
  bool interweave_lateral = false;        // (Z, sigma_z) with z
  int ancillary_steps = 1;
  int ancillary_every = 1;

  // Lateral jumps: on sweeps with it % lateral_jump_every == 0 every truck also proposes a new z
  // from its prior N(Z, sigma_z^2) on the road, (k, k_t) kept (an independence MH step whose
  // acceptance is the likelihood ratio: one batched call of N passes). A truck's z-likelihood can
  // have several peaks across the lane, which the random walk does not cross. Measured at 1,000
  // trucks, 8,000 sweeps (2,000 burn-in), chain seed 7, 2 threads:
  //   second fleet on AS2 (z broad and many-peaked): without jumps sigma_z 0.414 (truth 0.35), ESS
  //   17; jumps every sweep 0.341, ESS 1039, +47 % per sweep; every 5th sweep 0.341, ESS 1070, +14 %;
  //   Table 1 on AS1 (z pinned down, jump acceptance 0.055): the same ESS, but sigma_kt 179.3k
  //   without jumps and 174.4k / 175.7k with them (every sweep / every 5th; posterior sd 9.9k): a
  //   few trucks left in another lateral mode pull their k_t, and so sigma_kt, outwards. 0 = off.
  int lateral_jump_every = 5;
  // Joint jumps: on sweeps with it % joint_jump_every == 0 every truck also proposes all of
  // (k, k_t, z) from the fleet distribution given θ (and ψ, with an extension's stiffness
  // distribution), accepted by the likelihood ratio (batch_mcmc_jumps.hpp; one batched call of N
  // passes). For a truck with two joint modes that a z-only jump cannot link. 0 = off. Measured
  // (2 threads, chain seed 7, 30,000 sweeps of which 25,000 kept):
  //   second_class on 50 Table 1 trucks with a 30 % stiff class (the long extension test's data):
  //   with the classes' stiffness jump (ModelExtension::stiffness_jump) and no joint jumps, one
  //   stiff truck (k 1.23e6 N/m, z 0.95 m) stays in a softer mode on another lateral line (k 3.9e5,
  //   z 2.11) for the whole chain, and sigma_IF comes out 4.2 posterior sd above the SMC's; with jumps
  //   every 5th sweep (acceptance 0.014) the chain agrees with two latent SMC runs within 0.07
  //   posterior sd on all 10 parameters (K ESS 4326, the label-swapped classes visited 248 times);
  //   Table 1 on AS1, 1,000 trucks: +9 % integrator passes (65.9M -> 71.9M), the same ESS.
  int joint_jump_every = 5;

  // Threads for the batched integrator calls (0 = std::thread::hardware_concurrency()). The
  // draws do not depend on it.
  int threads = 0;

  // An optional model extension (model_extension.hpp; step 5 of the header): its parameters ψ join
  // the chain. Not owned; must outlive the call. nullptr = the base model.
  const ModelExtension* extension = nullptr;
  // Where ψ starts (inside its box, one value per parameter). Default: the best, by the log
  // posterior at the chain's starting θ and latents, of the parameters' null values (the base
  // model) and `psi_start_candidates` points of a Halton sequence over ψ's box (no random number
  // drawn; batch_mcmc_extension.hpp says why). Each candidate costs N passes when ψ edits the
  // forward model; when it only replaces the stiffness distribution, 64 times as many candidates
  // over (K, sigma_k, ψ) cost N densities each, and the start of (K, sigma_k) follows the best.
  // 0 candidates: the null values.
  std::optional<std::vector<double>> initial_psi;
  int psi_start_candidates = 1024;
  // Random-walk MH steps of ψ per sweep. With an extension that edits the forward model each is one
  // batched call of N passes, as much as the latent step, so one.
  int psi_moves_per_sweep = 1;
  // The extension's own jump (if it has one) on sweeps with it % psi_jump_every == 0 (0 = never).
  // N passes each; the jump exists for modes the random walk cannot cross (profile_defect's bump
  // and dip a wheel-hop wavelength apart), so it must keep coming after the chain has settled.
  int psi_jump_every = 1;
  // First proposal sd of each ψ coordinate as a fraction of its prior width, before the chain's
  // own covariance takes over in burn-in.
  double psi_initial_step = 0.01;
  // (K, sigma_k[, ψ]) random-walk MH steps per sweep with an extension's stiffness distribution
  // (O(N) each, no integrator call, as the (Z, sigma_z) steps).
  int stiffness_moves_per_sweep = 10;

  // False, with a message naming the option and the rule, if an option is out of range.
  bool IsValid(std::string* error) const;
};

struct BatchMcmcResult {
  // Kept draws of theta after burn-in, thinned: rows are draws, columns in Hyper order
  // (K, sigma_k, Kt, sigma_kt, Z, sigma_z, sigma_if).
  Eigen::MatrixXd theta_draws;
  // log of the unnormalised posterior density at each kept draw (a convergence trace).
  Eigen::VectorXd log_target;
  // With an extension: its parameters ψ at the same kept draws (rows), in parameters() order;
  // 0 columns without one.
  Eigen::MatrixXd psi_draws;

  // Per truck (rows, the records' order) posterior mean and sd of (k, kt, z), over every sweep
  // after burn-in (not thinned).
  std::vector<std::string> truck_ids;
  Eigen::MatrixXd latent_mean;
  Eigen::MatrixXd latent_sd;

  // Where the chain started (after the grid search).
  HyperVector initial_theta{};
  Eigen::MatrixXd initial_latents;

  // Acceptance rates after burn-in. Gibbs blocks accept always; sigma blocks report 1 unless
  // they fell back to MH (N < 2).
  Eigen::VectorXd latent_acceptance_per_truck;
  double latent_acceptance = 0.0;  // mean over trucks
  double z_acceptance = 0.0;       // (Z, sigma_z) joint MH
  double sigma_k_acceptance = 1.0, sigma_kt_acceptance = 1.0, sigma_if_acceptance = 1.0;
  // Ancillary (interweaving) MH steps after burn-in: (K, sigma_k), (K_t, sigma_kt), (Z, sigma_z);
  // 0 where the block was not interwoven.
  double ancillary_k_acceptance = 0.0, ancillary_kt_acceptance = 0.0, ancillary_z_acceptance = 0.0;
  double lateral_jump_acceptance = 0.0;  // after burn-in, over trucks and jump sweeps
  double joint_jump_acceptance = 0.0;    // the same for the joint (k, k_t, z) jumps
  // With an extension, after burn-in: ψ's random walk (or, when ψ moves with (K, sigma_k) in the
  // stiffness steps, those steps' acceptance), its jump (0 without one), and the (K, sigma_k[, ψ])
  // steps of an extension's stiffness distribution (also reported as sigma_k_acceptance).
  double psi_acceptance = 0.0;
  double psi_jump_acceptance = 0.0;
  double stiffness_acceptance = 0.0;
  std::vector<double> initial_psi;  // where ψ started (empty without an extension)
  int threads = 1;  // threads the integrator calls were split over
  // Final per-truck proposal scale multipliers (frozen after burn-in).
  Eigen::VectorXd latent_proposal_scale;

  long long integrator_passes = 0;  // trucks simulated, the grid search included
  long long integrator_calls = 0;   // batched evaluations (of up to 2048 trucks, each split over the threads)
  int iterations = 0;
  int burn_in = 0;
  double init_seconds = 0.0;  // grid search
  double wall_seconds = 0.0;  // everything
};

// Runs the sampler on WIM records (speed, sprung mass, one impact factor per sensor) at `site`.
// Throws UsageError on invalid options (the IsValid message) and DataError when a record's
// impact factors do not match the site's sensors or there are no records.
BatchMcmcResult run_batch_mcmc(const site::Site& site, const std::vector<records::WimRecord>& records,
                               const BatchMcmcOptions& options);

// log of the unnormalised posterior: log prior + sum_n log p(x_n | theta) + log-likelihood from
// the per-truck sums of squared residuals (sensors per truck `sensors`). latents: trucks x 3.
double log_posterior_unnormalised(const HyperVector& theta, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                                  const Eigen::Ref<const Eigen::VectorXd>& ssr, int sensors,
                                  const PriorBounds& prior, const LateralRange& range);
// The same with a model extension at ψ (the residuals computed at ψ): the extension's stiffness
// density for every k if it has one, and ψ's uniform prior added last. A null extension gives the
// base model's value; an extension at its null ψ gives that value plus ψ's log prior, bit for bit.
double log_posterior_unnormalised(const HyperVector& theta, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                                  const Eigen::Ref<const Eigen::VectorXd>& ssr, int sensors,
                                  const PriorBounds& prior, const LateralRange& range,
                                  const ModelExtension* extension, const double* psi);

}  // namespace ssrfleet::fleet
