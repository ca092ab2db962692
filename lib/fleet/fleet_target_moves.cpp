// The latent core's model moves (FleetTarget::model_moves): θ given the latents, the older trucks'
// latents, an extension's ψ and stiffness distribution; and the final rejuvenation sweeps. The
// schedule that says when each runs is FleetSmc::move_schedule; the densities are fleet_target.cpp's.
#include "fleet/fleet_target.hpp"
#include "fleet/fleet_target_draws.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>

#include "model/extended_forward.hpp"
#include "model/extension_conditionals.hpp"
#include "model/fleet_conditionals.hpp"
#include "model/truncated_samplers.hpp"
#include "smc/mh_kernel.hpp"
#include "smc/rng.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {

// Whether the particles differ anywhere in `state` (coordinates × particles). After a resampling
// from one dominant weight every particle is a copy of one, and a random walk scaled on the
// cloud's spread has no scale: such a move is skipped for that sweep (the Gibbs moves of θ and the
// latents' moves keep the chain going and restore the spread; skipping a kernel keeps the target
// invariant). Seen in a diagnose refit of a 50-truck log with a second class of trucks.
bool cloud_has_spread(const Eigen::Ref<const Eigen::MatrixXd>& state) {
  return (state.rowwise().maxCoeff() - state.rowwise().minCoeff()).maxCoeff() > 0.0;
}

}  // namespace

using detail::standard_normal;

std::vector<std::string> FleetTarget::model_moves() const {
  return {std::string(kOlderTrucksMove), std::string(kExtensionJumpMove), std::string(kExtensionWalkMove),
          std::string(kStiffnessMove), std::string(kThetaMove), std::string(kInterweaveMove)};
}

smc::TemperedModel::ModelMoveResult FleetTarget::run_model_move(int move, int run_in_stage, double phi,
                                                                const smc::RngFactory& rngs,
                                                                const smc::ParallelFor& parallel,
                                                                Eigen::Ref<Eigen::ArrayXd> log_base,
                                                                Eigen::Ref<Eigen::ArrayXd> loglik) {
  // Each move draws from its own child of rngs (the keys predate the schedule: same bits).
  // ψ moves with the likelihood when the extension edits the forward model and has a free parameter
  // (a model spec may fix them all).
  const bool extension_moves_forward =
      options_.extension != nullptr && options_.extension->edits_forward() && psi_.rows() > 0;
  switch (move) {
    case 0:  // older trucks
      if (kept_trucks() < 2) return {false};
      // Alternate a random walk on (k, k_t, z) with an independence proposal of (k, k_t) from
      // p(k, k_t | θ): one truck's data say little about its stiffnesses, so the prior proposal
      // is accepted often and moves them across their whole range, which the spread parameters
      // σ_k and σ_kt need (a random walk alone left them 0.4 posterior sd off a long MCMC).
      older_trucks_sweep(rngs.child(1), parallel, run_in_stage % 2 == 1, kept_trucks() - 1, older_scale_);
      return {true, older_acceptance_};
    case 1:  // extension jump
      if (!extension_moves_forward || options_.extension->jump_draws() == 0) return {false};
      extension_sweep(rngs.child(3), parallel, PsiMove::kJump);
      return {true, extension_jump_acceptance_};
    case 2:  // extension random walk
      if (!extension_moves_forward) return {false};
      extension_sweep(rngs.child(2), parallel, PsiMove::kRandomWalk);
      return {true, extension_acceptance_};
    case 3:  // stiffness distribution
      // Below φ = 1 the target holds the newest truck's proposal, built at the stage's θ
      // (Options::proposals): θ waits for φ = 1.
      if (!stiffness_edited() || (newest_from_proposals_ && phi < 1.0)) return {false};
      if (!stiffness_distribution_sweep(rngs.child(4), parallel)) return {false};
      return {true, stiffness_acceptance_};
    case 4:  // theta
      if (newest_from_proposals_ && phi < 1.0) return {false};  // as "stiffness distribution"
      theta_moves(phi, rngs.child(0), parallel, log_base, loglik);
      return {true};
    case 5:  // tyre stiffness interweave
      if (!tyre_stiffness_interweave(phi, rngs.child(5), parallel, log_base, loglik)) return {false};
      return {true, interweave_acceptance_};
    default:
      throw UsageError("fleet target: no model move " + std::to_string(move));
  }
}

void FleetTarget::rejuvenate(int sweeps, const smc::RngFactory& rngs, const smc::ParallelFor& parallel) {
  if (sweeps < 0) throw UsageError("fleet target: rejuvenation sweeps must be >= 0");
  if (kept_trucks() == 0) return;
  // The newest truck's proposal scale starts at 1 and adapts within this call; the older ones
  // carry on from the stages.
  std::vector<double> scales = older_scale_;
  scales.push_back(1.0);
  Eigen::ArrayXd log_base(options_.particles), loglik(options_.particles);  // not needed after φ = 1
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const smc::RngFactory r = rngs.child(static_cast<std::uint64_t>(sweep));
    older_trucks_sweep(r.child(1), parallel, sweep % 2 == 1, kept_trucks(), scales);
    if (options_.extension != nullptr && options_.extension->edits_forward() && psi_.rows() > 0) {
      extension_sweep(r.child(2), parallel, PsiMove::kRandomWalk);
    }
    if (stiffness_edited()) stiffness_distribution_sweep(r.child(4), parallel);
    tyre_stiffness_interweave(1.0, r.child(5), parallel, log_base, loglik);
    theta_moves(1.0, r.child(0), parallel, log_base, loglik);
  }
  scales.pop_back();
  older_scale_ = scales;
}

void FleetTarget::theta_moves(double phi, const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                              Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik) {
  const Eigen::Index newest = kept_trucks() - 1;
  const double n_all = static_cast<double>(trucks());  // the newest truck's latents are in γ in full
  const auto& prior = options_.prior;
  parallel(options_.particles, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      HyperVector t = theta_of(i);
      const double* s = sums_.col(i).data();
      const double* x = latents_.col(i).data() + 3 * newest;
      // Sums over all n+1 latents (older ones from the running sums, plus the newest).
      auto with_newest = [&](int sum, int sum2, int latent) {
        return LatentSums{n_all, s[sum] + x[latent], s[sum2] + x[latent] * x[latent]};
      };
      const LatentSums k = with_newest(kSumK, kSumK2, kStiffness), kt = with_newest(kSumKt, kSumKt2, kTyreStiffness);
      // (K, σ_k) have standard conditionals only under the base model's N(K, σ_k²); an extension's
      // stiffness distribution moves them in stiffness_distribution_sweep instead.
      if (!stiffness_edited()) t[kK] = draw_mean_given_latents(rng, k, t[kSigmaK], prior.lo[kK], prior.hi[kK]);
      t[kKt] = draw_mean_given_latents(rng, kt, t[kSigmaKt], prior.lo[kKt], prior.hi[kKt]);
      if (trucks() >= 2) {
        if (!stiffness_edited()) t[kSigmaK] = draw_sd_given_latents(rng, k, t[kK], prior.lo[kSigmaK], prior.hi[kSigmaK]);
        t[kSigmaKt] = draw_sd_given_latents(rng, kt, t[kKt], prior.lo[kSigmaKt], prior.hi[kSigmaKt]);
      }
      // (Z, σ_z): the Gaussian part of their conditional is standard; the truncation to the road
      // adds m(Z, σ_z)^-N (m = the road's share of N(Z, σ_z²)). Propose from the Gaussian part
      // on the prior box and accept with the ratio of m^-N: exact MH, accepting almost always.
      const LatentSums z = with_newest(kSumZ, kSumZ2, kLateral);
      const auto log_mass = [&](double mean, double sd) {
        return log_normal_mass(lateral_.lo_m, lateral_.hi_m, mean, sd);
      };
      {
        const double z_new = draw_mean_given_latents(rng, z, t[kSigmaZ], prior.lo[kZ], prior.hi[kZ]);
        const double log_accept = n_all * (log_mass(t[kZ], t[kSigmaZ]) - log_mass(z_new, t[kSigmaZ]));
        if (std::log(uniform_open01(rng)) < log_accept) t[kZ] = z_new;
      }
      if (trucks() >= 2) {
        const double sd_new = draw_sd_given_latents(rng, z, t[kZ], prior.lo[kSigmaZ], prior.hi[kSigmaZ]);
        const double log_accept = n_all * (log_mass(t[kZ], t[kSigmaZ]) - log_mass(t[kZ], sd_new));
        if (std::log(uniform_open01(rng)) < log_accept) t[kSigmaZ] = sd_new;
      }
      // σ_IF: older trucks' likelihoods count in full, the newest one's at power φ, so the
      // precision is Gamma((M(n+φ) - 1)/2, (ΣSSR + φ SSR_new)/2) on the box.
      const double ssr_new = ssr_(newest, i);
      if (std::isfinite(ssr_new) && std::isfinite(s[kSumSsr])) {
        const double observations = sensors_ * (n_all - 1.0 + phi), ssr = s[kSumSsr] + phi * ssr_new;
        if (observations > 1.0 && ssr > 0.0)
          t[kSigmaIf] = draw_noise_sd_given_ssr(rng, observations, ssr, prior.lo[kSigmaIf], prior.hi[kSigmaIf]);
      }
      for (int j = 0; j < kHyperCount; ++j) theta_(j, i) = t[j];
      log_base[i] = base_density(i, t, x);
      loglik[i] = newest_loglik(ssr_new, t[kSigmaIf]);
    }
  });
}

bool FleetTarget::tyre_stiffness_interweave(double phi, const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                                            Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik) {
  const Eigen::Index P = options_.particles, n = kept_trucks(), newest = n - 1;
  if (n < 2) return false;
  // The walk in (K_t, log σ_kt), on the cloud's spread (equal weights: this runs right after a
  // stage, whatever the weights), times a multiplier adapted on acceptance. The cloud's spread is
  // the marginal posterior's; the conditional given ε is narrower, which the multiplier takes up.
  Eigen::MatrixXd state(2, P);
  state.row(0) = theta_.row(kKt);
  state.row(1) = theta_.row(kSigmaKt).array().log().matrix();
  if (!cloud_has_spread(state)) return false;
  const Eigen::MatrixXd chol =
      Eigen::LLT<Eigen::MatrixXd>(smc::proposal_covariance(state, Eigen::ArrayXd::Ones(P), 2.38 * interweave_scale_))
          .matrixL();
  const auto& prior = options_.prior;
  Eigen::Matrix2Xd proposed(2, P);  // (K_t', σ_kt')
  Eigen::ArrayXd log_u(P);
  std::vector<char> inside(static_cast<std::size_t>(P), 0);
  Eigen::MatrixXd proposals = latents_;
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      const Eigen::Vector2d z(standard_normal(rng), standard_normal(rng));
      const Eigen::Vector2d step = chol * z;
      const double mean = theta_(kKt, i), sd = theta_(kSigmaKt, i);
      const double mean_new = mean + step[0], sd_new = sd * std::exp(step[1]);
      proposed.col(i) = Eigen::Vector2d(mean_new, sd_new);
      log_u[i] = std::log(uniform_open01(rng));
      const bool in_box = mean_new >= prior.lo[kKt] && mean_new <= prior.hi[kKt] && sd_new >= prior.lo[kSigmaKt] &&
                          sd_new <= prior.hi[kSigmaKt];
      inside[static_cast<std::size_t>(i)] = in_box ? 1 : 0;
      if (!in_box) continue;
      for (Eigen::Index j = 0; j < n; ++j) {
        double& kt = proposals(3 * j + kTyreStiffness, i);
        kt = mean_new + sd_new * (kt - mean) / sd;
      }
    }
  });
  // Every kept truck of every particle whose proposal is inside the box, at the proposal (a k_t
  // at or below zero gets an infinite SSR: rejected, as the centred latent moves do).
  const Eigen::MatrixXd new_ssr = every_kept_truck_ssr(proposals, psi_, inside, parallel);
  std::vector<char> moved(static_cast<std::size_t>(P), 0);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      if (!inside[static_cast<std::size_t>(i)] || !new_ssr.col(i).allFinite()) continue;
      const double sigma_if = theta_(kSigmaIf, i);
      double log_ratio = std::log(proposed(1, i) / theta_(kSigmaKt, i));  // the log-scale walk's Jacobian
      for (Eigen::Index j = 0; j < n; ++j) {
        const double power = j == newest ? phi : 1.0;
        log_ratio += power * (log_likelihood_from_ssr(new_ssr(j, i), sensors_, sigma_if) -
                              log_likelihood_from_ssr(ssr_(j, i), sensors_, sigma_if));
      }
      if (!(log_u[i] < log_ratio)) continue;
      theta_(kKt, i) = proposed(0, i);
      theta_(kSigmaKt, i) = proposed(1, i);
      latents_.col(i) = proposals.col(i);
      ssr_.col(i) = new_ssr.col(i);
      recompute_sums(i);
      log_base[i] = base_density(i, theta_of(i), latents_.col(i).data() + 3 * newest);
      loglik[i] = newest_loglik(ssr_(newest, i), theta_(kSigmaIf, i));
      moved[static_cast<std::size_t>(i)] = 1;
    }
  });
  // A serial reduction: the same whatever the threads.
  interweave_acceptance_ = static_cast<double>(std::count(moved.begin(), moved.end(), 1)) / static_cast<double>(P);
  interweave_scale_ = smc::tuned_scale_factor(interweave_scale_, interweave_acceptance_);
  return true;
}

void FleetTarget::older_trucks_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                                     bool stiffness_from_prior, Eigen::Index swept, std::vector<double>& scales) {
  const Eigen::Index P = options_.particles, older = swept;
  // Per truck: a proposal from the particle cloud's spread of that truck's latents (equal
  // weights: this runs right after a stage, whatever the weights), scaled by 2.38/√3 and by a
  // multiplier adapted on acceptance from stage to stage.
  std::vector<Eigen::Matrix3d> chol(static_cast<std::size_t>(older));
  const Eigen::ArrayXd equal = Eigen::ArrayXd::Constant(P, 1.0);
  for (Eigen::Index j = 0; j < older; ++j) {
    const Eigen::MatrixXd x = latents_.middleRows(3 * j, 3);
    const Eigen::VectorXd mean = x.rowwise().mean();
    const Eigen::MatrixXd centred = x.colwise() - mean;
    Eigen::Matrix3d cov = centred * centred.transpose() / static_cast<double>(P);
    // A ridge keeps a collapsed coordinate movable: 1e-6 of the prior scale of each latent.
    cov.diagonal() += Eigen::Vector3d(1e-6 * 5e4, 1e-6 * 2e5, 1e-6 * 0.5).array().square().matrix();
    const double scale = scales[static_cast<std::size_t>(j)] * 2.38 / std::sqrt(3.0);
    chol[static_cast<std::size_t>(j)] = Eigen::LLT<Eigen::Matrix3d>(cov).matrixL();
    chol[static_cast<std::size_t>(j)] *= scale;
  }
  // Proposals: particle i's draws come from its own stream, truck by truck in order.
  Eigen::MatrixXd proposals(3 * older, P);
  Eigen::ArrayXd log_u(older * P);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      const HyperVector t = theta_of(i);
      for (Eigen::Index j = 0; j < older; ++j) {
        if (stiffness_from_prior) {
          proposals(3 * j + kStiffness, i) = draw_stiffness(rng, t, psi_.col(i).data());
          proposals(3 * j + kTyreStiffness, i) = t[kKt] + t[kSigmaKt] * standard_normal(rng);
          proposals(3 * j + kLateral, i) = latents_(3 * j + kLateral, i);
        } else {
          const Eigen::Vector3d z(standard_normal(rng), standard_normal(rng), standard_normal(rng));
          proposals.block(3 * j, i, 3, 1) = latents_.block(3 * j, i, 3, 1) + chol[static_cast<std::size_t>(j)] * z;
        }
        log_u[i * older + j] = std::log(uniform_open01(rng));
      }
    }
  });
  // Simulate every (particle, older truck) proposal; chunks of particles run in parallel.
  Eigen::MatrixXd new_ssr(older, P);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<SsrJob> jobs;
    for (Eigen::Index i = begin; i < end; ++i) {
      for (Eigen::Index j = 0; j < older; ++j) {
        jobs.push_back({j, proposals.col(i).data() + 3 * j, &new_ssr(j, i), psi_.col(i).data()});
      }
    }
    simulate_ssr(jobs);
  });
  passes_ += older * P;
  // Accept per (particle, truck): only truck j's own terms change, given θ.
  std::vector<char> took(static_cast<std::size_t>(older * P), 0);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const HyperVector t = theta_of(i);
      for (Eigen::Index j = 0; j < older; ++j) {
        if (!std::isfinite(new_ssr(j, i))) continue;
        // With the stiffnesses proposed from p(k, k_t | θ), their density cancels against the
        // proposal's and the MH ratio is the likelihood ratio.
        const auto terms = [&](const double* x, double ssr) {
          const double prior = stiffness_from_prior ? 0.0 : latent_log_density(x, t, psi_.col(i).data());
          return prior + log_likelihood_from_ssr(ssr, sensors_, t[kSigmaIf]);
        };
        const double log_ratio = terms(proposals.col(i).data() + 3 * j, new_ssr(j, i)) -
                                 terms(latents_.col(i).data() + 3 * j, ssr_(j, i));
        if (log_u[i * older + j] < log_ratio) {
          latents_.block(3 * j, i, 3, 1) = proposals.block(3 * j, i, 3, 1);
          ssr_(j, i) = new_ssr(j, i);
          took[static_cast<std::size_t>(i * older + j)] = 1;
        }
      }
      recompute_sums(i);
    }
  });
  if (stiffness_from_prior) {  // the random walk's scale adapts on its own acceptance only
    older_acceptance_ = static_cast<double>(std::count(took.begin(), took.end(), 1)) / static_cast<double>(took.size());
    return;
  }
  // Acceptance per truck (a serial reduction after the loop: the same whatever the threads).
  double total = 0.0;
  for (Eigen::Index j = 0; j < older; ++j) {
    Eigen::Index moved = 0;
    for (Eigen::Index i = 0; i < P; ++i) moved += took[static_cast<std::size_t>(i * older + j)];
    const double rate = static_cast<double>(moved) / static_cast<double>(P);
    auto& scale = scales[static_cast<std::size_t>(j)];
    scale = smc::tuned_scale_factor(scale, rate);
    total += rate;
  }
  older_acceptance_ = total / static_cast<double>(older);
}

void FleetTarget::extension_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel, PsiMove move) {
  const Eigen::Index P = options_.particles, n = kept_trucks(), d = psi_.rows();
  const ModelExtension& ext = *options_.extension;
  // Proposal: a random walk in the extension's move coordinates u (ModelExtension::
  // to_move_coordinates; ψ itself unless it defines them), on the cloud's spread of u (equal
  // weights), 2.38/√d, times a multiplier adapted on acceptance; a ridge of 1e-4 of how far each
  // coordinate moves across its box keeps a collapsed coordinate movable.
  Eigen::MatrixXd u(d, P);
  for (Eigen::Index i = 0; i < P; ++i) ext.to_move_coordinates(psi_.col(i).data(), u.col(i).data());
  const Eigen::VectorXd mean = u.rowwise().mean();
  const Eigen::MatrixXd centred = u.colwise() - mean;
  Eigen::MatrixXd cov = centred * centred.transpose() / static_cast<double>(P);
  const std::vector<double> spans = ext.move_coordinate_spans();
  for (Eigen::Index j = 0; j < d; ++j) cov(j, j) += std::pow(1e-4 * spans[static_cast<std::size_t>(j)], 2);
  Eigen::MatrixXd chol = Eigen::LLT<Eigen::MatrixXd>(cov).matrixL();
  chol *= extension_scale_ * 2.38 / std::sqrt(static_cast<double>(d));
  Eigen::MatrixXd proposals(d, P);
  Eigen::ArrayXd log_u(P);
  std::vector<char> inside(static_cast<std::size_t>(P), 0);
  for (Eigen::Index i = 0; i < P; ++i) {
    smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
    if (move == PsiMove::kJump) {
      std::vector<double> u(static_cast<std::size_t>(ext.jump_draws()));
      for (double& v : u) v = smc::uniform01(rng);
      ext.jump(psi_.col(i).data(), u.data(), proposals.col(i).data());
    } else {
      Eigen::VectorXd z(d);
      for (Eigen::Index j = 0; j < d; ++j) z[j] = standard_normal(rng);
      const Eigen::VectorXd v = u.col(i) + chol * z;
      ext.from_move_coordinates(v.data(), proposals.col(i).data());
    }
    log_u[i] = std::log(uniform_open01(rng));
    inside[static_cast<std::size_t>(i)] = ext.in_prior(proposals.col(i).data()) ? 1 : 0;
  }
  // Every kept truck of every particle whose proposal is inside the prior, at the proposal.
  const Eigen::MatrixXd new_ssr = every_kept_truck_ssr(latents_, proposals, inside, parallel);
  Eigen::Index moved = 0;
  for (Eigen::Index i = 0; i < P; ++i) {
    if (!inside[static_cast<std::size_t>(i)]) continue;
    // Uniform prior: inside the box, the ratio is the likelihood ratio over every kept truck
    // (the newest included, at φ = 1).
    const double s_new = new_ssr.col(i).sum(), s_old = ssr_.col(i).sum();
    if (!std::isfinite(s_new)) continue;
    // With an extension's stiffness distribution ψ also changes the density of every kept truck's k.
    // A walk in u targets π(ψ(u)) |det ∂ψ/∂u|: its ratio gains the Jacobian's (the jump is in ψ).
    const double log_jacobian_ratio =
        move == PsiMove::kJump ? 0.0
                               : ext.log_move_jacobian(proposals.col(i).data()) - ext.log_move_jacobian(psi_.col(i).data());
    const double log_ratio =
        log_psi_ratio(ext, proposals.col(i).data(), psi_.col(i).data(), s_new, s_old, theta_(kSigmaIf, i),
                      latents_.col(i).data() + kStiffness, n, 3, theta_(kK, i), theta_(kSigmaK, i)) +
        log_jacobian_ratio;
    if (log_u[i] < log_ratio) {
      psi_.col(i) = proposals.col(i);
      ssr_.col(i) = new_ssr.col(i);
      recompute_sums(i);
      ++moved;
    }
  }
  if (move == PsiMove::kJump) {  // the random walk's scale adapts on its own acceptance only
    extension_jump_acceptance_ = static_cast<double>(moved) / static_cast<double>(P);
    return;
  }
  extension_acceptance_ = static_cast<double>(moved) / static_cast<double>(P);
  extension_scale_ = smc::tuned_scale_factor(extension_scale_, extension_acceptance_);
}

bool FleetTarget::stiffness_distribution_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel) {
  const ModelExtension& ext = *options_.extension;
  const Eigen::Index P = options_.particles, n = kept_trucks();
  if (n == 0) return false;
  const bool with_psi = !ext.edits_forward();  // otherwise ψ moves in extension_sweep, with the likelihood
  const Eigen::Index d = 2 + (with_psi ? psi_.rows() : 0);
  Eigen::MatrixXd state(d, P);  // (K, σ_k[, ψ]) per particle
  state.row(0) = theta_.row(kK);
  state.row(1) = theta_.row(kSigmaK);
  if (with_psi) state.bottomRows(psi_.rows()) = psi_;
  if (!cloud_has_spread(state)) return false;
  const Eigen::MatrixXd chol =
      Eigen::LLT<Eigen::MatrixXd>(smc::proposal_covariance(state, Eigen::ArrayXd::Ones(P), 2.38 * stiffness_scale_)).matrixL();
  const auto& prior = options_.prior;
  // log p(K, σ_k, ψ | every kept truck's k) up to a constant: the uniform boxes and the trucks'
  // stiffness densities (the newest truck's in full: its latents are in γ at every φ).
  const auto log_density = [&](Eigen::Index i, const Eigen::VectorXd& x) {
    const double* psi = with_psi ? x.data() + 2 : psi_.col(i).data();
    return log_stiffness_conditional(ext, x[0], x[1], psi, latents_.col(i).data() + kStiffness, n, 3, prior);
  };
  // The extension's jump of (K, σ_k, ψ) (second_class: the classes trade places), once per call
  // before the walk: the walk, scaled on the cloud, does not cross between such modes.
  const bool jump = with_psi && ext.stiffness_jump_draws() > 0;
  std::vector<int> moved(static_cast<std::size_t>(P), 0), jumped(static_cast<std::size_t>(P), 0);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    Eigen::VectorXd z(d), y(d);
    std::vector<double> u(static_cast<std::size_t>(ext.stiffness_jump_draws()));
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      Eigen::VectorXd x = state.col(i);
      double lp = log_density(i, x);
      if (jump) {
        for (double& v : u) v = smc::uniform01(rng);
        ext.stiffness_jump(x.data() + 2, x[0], x[1], u.data(), y.data() + 2, &y[0], &y[1]);
        const double lp_new = log_density(i, y);
        if (std::log(uniform_open01(rng)) < lp_new - lp) {
          x = y;
          lp = lp_new;
          jumped[static_cast<std::size_t>(i)] = 1;
        }
      }
      for (int step = 0; step < kStiffnessSteps; ++step) {
        for (Eigen::Index j = 0; j < d; ++j) z[j] = standard_normal(rng);
        const Eigen::VectorXd y = x + chol * z;
        const double lp_new = log_density(i, y);
        if (std::log(uniform_open01(rng)) < lp_new - lp) {
          x = y;
          lp = lp_new;
          ++moved[static_cast<std::size_t>(i)];
        }
      }
      theta_(kK, i) = x[0];
      theta_(kSigmaK, i) = x[1];
      if (with_psi) psi_.col(i) = x.tail(psi_.rows());
    }
  });
  // A serial reduction: the same whatever the threads.
  double total = 0.0;
  for (int m : moved) total += m;
  stiffness_acceptance_ = total / static_cast<double>(P * kStiffnessSteps);
  if (jump) {
    extension_jump_acceptance_ =
        static_cast<double>(std::count(jumped.begin(), jumped.end(), 1)) / static_cast<double>(P);
  }
  stiffness_scale_ = smc::tuned_scale_factor(stiffness_scale_, stiffness_acceptance_);
  return true;
}

}  // namespace ssrfleet::fleet
