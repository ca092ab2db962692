// The batch MCMC's chain (batch_mcmc.hpp): one sweep after another, the latents, θ and, with an
// extension, ψ; the kept draws and their summaries. Where it starts is batch_mcmc_start.cpp, its
// option rules batch_mcmc_options.cpp, an extension's steps batch_mcmc_extension.cpp.
#include "fleet/batch_mcmc.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <thread>

#include <Eigen/Cholesky>
#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>

#include "fleet/batch_mcmc_extension.hpp"
#include "fleet/batch_mcmc_interweave.hpp"
#include "fleet/batch_mcmc_jumps.hpp"
#include "fleet/batch_mcmc_residuals.hpp"
#include "fleet/batch_mcmc_start.hpp"
#include "model/extension_conditionals.hpp"
#include "model/fleet_conditionals.hpp"
#include "model/truncated_samplers.hpp"
#include "util/errors.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::fleet {

namespace {

using detail::ChainStart;
using detail::choose_psi_start;
using detail::ExtensionSteps;
using detail::gather;
using detail::JumpCounts;
using detail::LatentJumps;
using detail::Observations;
using detail::ResidualEvaluator;
using detail::start_chain;

using Engine = boost::random::mt19937_64;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double log_uniform(Engine& engine) { return std::log(uniform_open01(engine)); }

// Running mean and covariance (Welford) of a small vector.
template <int D>
struct RunningMoments {
  using Vec = Eigen::Matrix<double, D, 1>;
  using Mat = Eigen::Matrix<double, D, D>;
  long long count = 0;
  Vec mean = Vec::Zero();
  Mat m2 = Mat::Zero();
  void add(const Vec& x) {
    ++count;
    const Vec delta = x - mean;
    mean += delta / static_cast<double>(count);
    m2 += delta * (x - mean).transpose();
  }
  Mat covariance() const { return count > 1 ? Mat(m2 / static_cast<double>(count - 1)) : Mat(Mat::Zero()); }
  void reset() { *this = RunningMoments{}; }
};

// sigma | S, n with sigma uniform on [lo, hi] when the Gamma shape (n-1)/2 is not positive:
// random-walk MH on log sigma (with its Jacobian). Returns the number of accepted steps.
int sigma_mh(Engine& engine, double& sigma, int n, double sum_squares, double lo, double hi, int steps) {
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  auto log_f = [&](double s) { return -n * std::log(s) - sum_squares / (2.0 * s * s); };
  int accepted = 0;
  for (int i = 0; i < steps; ++i) {
    const double proposal = sigma * std::exp(0.5 * normal(engine));
    if (!(proposal >= lo && proposal <= hi)) continue;
    const double log_alpha = log_f(proposal) - log_f(sigma) + std::log(proposal / sigma);
    if (log_uniform(engine) < log_alpha) {
      sigma = proposal;
      ++accepted;
    }
  }
  return accepted;
}

}  // namespace

BatchMcmcResult run_batch_mcmc(const site::Site& site, const std::vector<records::WimRecord>& records,
                               const BatchMcmcOptions& options) {
  const Clock::time_point start = Clock::now();
  std::string error;
  if (!options.IsValid(&error)) throw UsageError(error);
  const Observations obs = gather(site, records);
  const int N = obs.trucks, M = obs.sensors;
  const PriorBounds& prior = options.prior;
  const LateralRange range{site.lateral_min_m(), site.lateral_max_m()};
  const ModelExtension* extension = options.extension;
  // ψ (empty without an extension): where it starts, and the pointer every simulation reads it by.
  std::vector<double> psi0;
  if (extension != nullptr) {
    if (options.initial_psi) psi0 = *options.initial_psi;
    else
      for (const auto& p : extension->parameters()) psi0.push_back(p.null_value);
  }
  const bool stiffness_edited = edits_stiffness(extension);

  Engine engine(options.seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  ResidualEvaluator evaluator(site, obs, threads, extension);

  BatchMcmcResult result;
  result.threads = threads;
  result.iterations = options.iterations;
  result.burn_in = options.burn_in;
  result.truck_ids.reserve(records.size());
  for (const auto& r : records) result.truck_ids.push_back(r.truck_id);

  // ---- initialisation ----
  std::vector<int> all(static_cast<std::size_t>(N));  // every truck's index
  for (int n = 0; n < N; ++n) all[static_cast<std::size_t>(n)] = n;
  ChainStart chain_start = start_chain(site, records, options, obs, evaluator, extension ? psi0.data() : nullptr);
  Eigen::MatrixXd& x = chain_start.latents;  // latents, one row per truck
  Eigen::ArrayXd& ssr = chain_start.ssr;
  HyperVector theta = chain_start.theta;
  result.integrator_passes += chain_start.fit_passes;
  if (extension != nullptr && !options.initial_psi) {
    choose_psi_start(*extension, options, theta, x, ssr, evaluator, all, psi0);
  }
  result.init_seconds = seconds_since(start);
  result.initial_theta = theta;
  result.initial_latents = x;
  result.initial_psi = psi0;
  // ψ's steps (step 5 of the header); every simulation reads the current ψ through psi_now().
  std::optional<ExtensionSteps> extension_steps;
  if (extension != nullptr) extension_steps.emplace(*extension, psi0, options, theta, N);
  const auto psi_now = [&]() -> const double* { return extension_steps ? extension_steps->psi().data() : nullptr; };

  // ---- proposal state (adapted during burn-in, frozen afterwards) ----
  const double default_log_scale = std::log(2.38 / std::sqrt(3.0));
  Eigen::ArrayXd log_scale = Eigen::ArrayXd::Constant(N, default_log_scale);
  std::vector<Eigen::Matrix3d> chol(static_cast<std::size_t>(N));
  {
    const Eigen::Vector3d init_sd(0.02 * std::max(theta[kK], 1.0), 0.02 * std::max(theta[kKt], 1.0),
                                  std::min(0.05, 0.05 * (range.hi_m - range.lo_m)));
    for (auto& L : chol) L = init_sd.asDiagonal();
  }
  std::vector<RunningMoments<3>> latent_moments(static_cast<std::size_t>(N));
  std::vector<bool> using_chain_covariance(static_cast<std::size_t>(N), false);
  const int adapt_start = options.burn_in / 4;  // the first quarter of burn-in is transient
  constexpr int kCovarianceEvery = 50;

  double z_log_scale = 0.0;
  Eigen::Vector2d z_base_sd(0.05, 0.03);
  RunningMoments<2> z_moments;

  // ---- accumulators ----
  const int kept = (options.iterations - options.burn_in + options.thin - 1) / options.thin;
  result.theta_draws.resize(kept, kHyperCount);
  result.log_target.resize(kept);
  result.psi_draws.resize(kept, extension != nullptr ? extension->dim() : 0);
  Eigen::ArrayXd accepted_after_burn_in = Eigen::ArrayXd::Zero(N);
  long long z_accepted_after = 0, z_tried_after = 0;
  long long sk_acc = 0, sk_try = 0, skt_acc = 0, skt_try = 0, sif_acc = 0, sif_try = 0;
  std::vector<RunningMoments<3>> latent_posterior(static_cast<std::size_t>(N));
  double report_latent_acc = 0.0, report_z_acc = 0.0;
  long long report_sweeps = 0, report_z_tries = 0;

  // Work arrays for the latent block.
  Eigen::MatrixXd proposal(N, kLatentCount);
  Eigen::ArrayXd log_prior_ratio(N);
  std::vector<int> valid;
  valid.reserve(static_cast<std::size_t>(N));
  Eigen::ArrayXd k_prop, kt_prop, z_prop, ssr_prop;
  LatentJumps jumps(extension, range);
  JumpCounts lateral_jump_counts, joint_jump_counts;

  // Interweaving: one ancillary updater per interwoven block, and the SSR of every truck with
  // one latent coordinate replaced (the other two at their current values).
  const bool interweave = options.interweave && !options.freeze_latents;
  AncillaryUpdater ancillary_k(kK, kSigmaK, false, N), ancillary_kt(kKt, kSigmaKt, false, N),
      ancillary_z(kZ, kSigmaZ, true, N);
  Eigen::ArrayXd latent_column;
  auto ssr_with = [&](int latent) {
    return [&, latent](const Eigen::ArrayXd& values, Eigen::ArrayXd& ssr_out) {
      const Eigen::ArrayXd k = latent == kStiffness ? values : Eigen::ArrayXd(x.col(kStiffness).array());
      const Eigen::ArrayXd kt =
          latent == kTyreStiffness ? values : Eigen::ArrayXd(x.col(kTyreStiffness).array());
      const Eigen::ArrayXd z = latent == kLateral ? values : Eigen::ArrayXd(x.col(kLateral).array());
      evaluator.evaluate(all, k, kt, z, psi_now(), ssr_out);
    };
  };
  const AncillarySsrFunction ssr_with_k = ssr_with(kStiffness), ssr_with_kt = ssr_with(kTyreStiffness),
                             ssr_with_z = ssr_with(kLateral);
  auto ancillary_steps = [&](AncillaryUpdater& updater, int latent, const AncillarySsrFunction& ssr_of,
                             bool burning_in, bool collect) {
    latent_column = x.col(latent).array();
    const double inv2var_if = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
    for (int s = 0; s < options.ancillary_steps; ++s) {
      updater.step(engine, theta, latent_column, ssr, inv2var_if, ssr_of, prior, range,
                   options.target_acceptance, burning_in, collect);
    }
    x.col(latent) = latent_column.matrix();
  };

  int kept_index = 0;
  for (int it = 0; it < options.iterations; ++it) {
    util::throw_if_stopped();
    if (it == options.burn_in) {
      ancillary_k.reset_counts();
      ancillary_kt.reset_counts();
      ancillary_z.reset_counts();
    }
    const bool burning_in = it < options.burn_in;
    const bool hold_theta = it < std::min(options.hold_theta_sweeps, options.burn_in);

    // ---- 1. latents: one batched integrator call for every truck's proposal ----
    double sweep_acc = 0.0;
    if (!options.freeze_latents) {
      valid.clear();
      for (int n = 0; n < N; ++n) {
        const Eigen::Vector3d eps(normal(engine), normal(engine), normal(engine));
        proposal.row(n) =
            x.row(n) + (std::exp(log_scale[n]) * (chol[static_cast<std::size_t>(n)] * eps)).transpose();
        const double k = proposal(n, kStiffness), kt = proposal(n, kTyreStiffness), z = proposal(n, kLateral);
        if (k > 0.0 && kt > 0.0 && z >= range.lo_m && z <= range.hi_m) valid.push_back(n);
      }
      const auto V = static_cast<Eigen::Index>(valid.size());
      k_prop.resize(V);
      kt_prop.resize(V);
      z_prop.resize(V);
      for (Eigen::Index i = 0; i < V; ++i) {
        const int n = valid[static_cast<std::size_t>(i)];
        k_prop[i] = proposal(n, kStiffness);
        kt_prop[i] = proposal(n, kTyreStiffness);
        z_prop[i] = proposal(n, kLateral);
      }
      if (V > 0) evaluator.evaluate(valid, k_prop, kt_prop, z_prop, psi_now(), ssr_prop);
      const double inv2var_if = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
      // k's fleet density: N(K, sigma_k^2), or an extension's stiffness distribution.
      const auto log_k = [&](double k) {
        return log_stiffness_density(extension, psi_now(), k, theta[kK], theta[kSigmaK]);
      };
      Eigen::ArrayXd accept_prob = Eigen::ArrayXd::Zero(N);
      for (Eigen::Index i = 0; i < V; ++i) {
        const int n = valid[static_cast<std::size_t>(i)];
        // The truncation normaliser of z depends on theta only and cancels here.
        const double log_alpha =
            -(ssr_prop[i] - ssr[n]) * inv2var_if +
            log_k(proposal(n, kStiffness)) - log_k(x(n, kStiffness)) +
            log_normal_density(proposal(n, kTyreStiffness), theta[kKt], theta[kSigmaKt]) -
            log_normal_density(x(n, kTyreStiffness), theta[kKt], theta[kSigmaKt]) +
            log_normal_density(proposal(n, kLateral), theta[kZ], theta[kSigmaZ]) -
            log_normal_density(x(n, kLateral), theta[kZ], theta[kSigmaZ]);
        accept_prob[n] = std::isfinite(log_alpha) ? std::min(1.0, std::exp(log_alpha)) : 0.0;
        if (log_uniform(engine) < log_alpha) {
          x.row(n) = proposal.row(n);
          ssr[n] = ssr_prop[i];
          if (!burning_in) accepted_after_burn_in[n] += 1.0;
        }
      }
      sweep_acc = accept_prob.mean();

      // Independence jumps from the fleet distribution (batch_mcmc_jumps.hpp): z alone, then (k, k_t, z).
      if (options.lateral_jump_every > 0 && it % options.lateral_jump_every == 0) {
        jumps.lateral(engine, theta, psi_now(), x, ssr, evaluator, all, !burning_in, lateral_jump_counts);
      }
      if (options.joint_jump_every > 0 && it % options.joint_jump_every == 0) {
        jumps.joint(engine, theta, psi_now(), x, ssr, evaluator, !burning_in, joint_jump_counts);
      }

      // Adaptation (burn-in only): Robbins-Monro on each truck's log scale towards the target
      // acceptance, and the truck's own chain covariance as the proposal shape.
      if (burning_in) {
        const double gain = std::min(1.0, 3.0 * std::pow(it + 1.0, -0.6));
        log_scale += gain * (accept_prob - options.target_acceptance);
        log_scale = log_scale.max(default_log_scale - 12.0).min(default_log_scale + 5.0);
        if (it >= adapt_start) {
          for (int n = 0; n < N; ++n) latent_moments[static_cast<std::size_t>(n)].add(x.row(n).transpose());
          if ((it - adapt_start + 1) % kCovarianceEvery == 0) {
            for (int n = 0; n < N; ++n) {
              const auto& mom = latent_moments[static_cast<std::size_t>(n)];
              if (mom.count < 2 * kCovarianceEvery) continue;
              Eigen::Matrix3d cov = mom.covariance();
              const Eigen::Vector3d var = cov.diagonal();
              if (!(var.array() > 0.0).all()) continue;  // this truck has not moved in every coordinate yet
              cov.diagonal() += 1e-6 * var;              // keeps the factor well conditioned
              const Eigen::LLT<Eigen::Matrix3d> llt(cov);
              if (llt.info() != Eigen::Success) continue;
              chol[static_cast<std::size_t>(n)] = llt.matrixL();
              if (!using_chain_covariance[static_cast<std::size_t>(n)]) {
                // First switch from the generic diagonal shape: restart at the optimal scaling for
                // a Gaussian target in 3 dimensions (Roberts, Gelman & Gilks 1997).
                using_chain_covariance[static_cast<std::size_t>(n)] = true;
                log_scale[n] = default_log_scale;
              }
            }
          }
        }
      }
    }

    // ---- 2-4. hyperparameters ----
    if (!hold_theta) {
      // Each block reads its latent column when it runs: an ancillary step moves that column.
      // K | k, sigma_k ~ N(mean k, sigma_k^2 / N) on the box; then sigma_k | k, K.
      auto mean_and_scale = [&](const Eigen::VectorXd& v, int mean_index, int sd_index, long long& acc,
                                long long& tries) {
        const auto mi = static_cast<std::size_t>(mean_index), si = static_cast<std::size_t>(sd_index);
        const LatentSums sums{static_cast<double>(N), v.sum(), v.squaredNorm()};
        theta[mi] = draw_mean_given_latents(engine, sums, theta[si], prior.lo[mi], prior.hi[mi]);
        const double ss = sums.squares_about(theta[mi]);
        if (N >= 2) {
          theta[si] = draw_sd_given_latents(engine, sums, theta[mi], prior.lo[si], prior.hi[si]);
          ++acc;
          ++tries;
        } else {
          acc += sigma_mh(engine, theta[si], N, ss, prior.lo[si], prior.hi[si], 5);
          tries += 5;
        }
      };
      const bool collect = burning_in && it >= adapt_start;
      const bool ancillary_sweep = interweave && it % options.ancillary_every == 0;
      if (stiffness_edited) {
        // No conjugate step under an extension's stiffness distribution: MH on its conditional.
        extension_steps->stiffness_steps(engine, it, theta, x, burning_in, collect);
      } else {
        mean_and_scale(x.col(kStiffness), kK, kSigmaK, sk_acc, sk_try);
      }
      if (ancillary_sweep && options.interweave_stiffness)
        ancillary_steps(ancillary_k, kStiffness, ssr_with_k, burning_in, collect);
      mean_and_scale(x.col(kTyreStiffness), kKt, kSigmaKt, skt_acc, skt_try);
      if (ancillary_sweep && options.interweave_tyre_stiffness)
        ancillary_steps(ancillary_kt, kTyreStiffness, ssr_with_kt, burning_in, collect);

      // (Z, sigma_z): joint random-walk MH; the truncation normaliser breaks conjugacy.
      const Eigen::VectorXd z =
          x.col(kLateral);  // a copy: the same sums, bit for bit, as before interweaving
      const LatentSums z_sums{static_cast<double>(N), z.sum(), z.squaredNorm()};
      double current = log_lateral_sum(z_sums, theta[kZ], theta[kSigmaZ], range);
      const Eigen::Vector2d step = std::exp(z_log_scale) * z_base_sd;
      int z_acc = 0;
      for (int s = 0; s < options.z_moves_per_sweep; ++s) {
        const double Z = theta[kZ] + step[0] * normal(engine);
        const double sz = theta[kSigmaZ] + step[1] * normal(engine);
        double alpha_prob = 0.0;
        if (Z >= prior.lo[kZ] && Z <= prior.hi[kZ] && sz >= prior.lo[kSigmaZ] && sz <= prior.hi[kSigmaZ]) {
          const double candidate = log_lateral_sum(z_sums, Z, sz, range);
          const double log_alpha = candidate - current;
          alpha_prob = std::isfinite(log_alpha) ? std::min(1.0, std::exp(log_alpha)) : 0.0;
          if (log_uniform(engine) < log_alpha) {
            theta[kZ] = Z;
            theta[kSigmaZ] = sz;
            current = candidate;
            ++z_acc;
          }
        }
        if (burning_in) {
          const double gain = std::min(1.0, 3.0 * std::pow(it * options.z_moves_per_sweep + s + 1.0, -0.6));
          z_log_scale = std::clamp(z_log_scale + gain * (alpha_prob - options.target_acceptance), -15.0, 5.0);
        }
      }
      if (burning_in && it >= adapt_start) {
        z_moments.add(Eigen::Vector2d(theta[kZ], theta[kSigmaZ]));
        if (z_moments.count >= 200 && z_moments.count % kCovarianceEvery == 0) {
          const Eigen::Vector2d sd = z_moments.covariance().diagonal().cwiseSqrt();
          if ((sd.array() > 0.0).all()) z_base_sd = 2.38 / std::sqrt(2.0) * sd;
        }
      }
      if (ancillary_sweep && options.interweave_lateral)
        ancillary_steps(ancillary_z, kLateral, ssr_with_z, burning_in, collect);
      report_z_acc += z_acc;
      report_z_tries += options.z_moves_per_sweep;
      if (!burning_in) {
        z_accepted_after += z_acc;
        z_tried_after += options.z_moves_per_sweep;
      }

      // sigma_IF | residuals: N M observations, S = total of the cached per-truck SSR.
      const int n_obs = N * M;
      if (n_obs >= 2) {
        theta[kSigmaIf] = draw_noise_sd_given_ssr(engine, static_cast<double>(n_obs), ssr.sum(), prior.lo[kSigmaIf],
                                                  prior.hi[kSigmaIf]);
        ++sif_acc;
        ++sif_try;
      } else {
        sif_acc +=
            sigma_mh(engine, theta[kSigmaIf], n_obs, ssr.sum(), prior.lo[kSigmaIf], prior.hi[kSigmaIf], 5);
        sif_try += 5;
      }

      // ψ: the extension's jump and random walk (after θ, so without an extension nothing is drawn).
      if (extension_steps) extension_steps->psi_steps(engine, it, theta, x, ssr, evaluator, all, burning_in, collect);
    }

    // ---- record ----
    if (!burning_in) {
      for (int n = 0; n < N; ++n) latent_posterior[static_cast<std::size_t>(n)].add(x.row(n).transpose());
      if ((it - options.burn_in) % options.thin == 0) {
        for (int j = 0; j < kHyperCount; ++j)
          result.theta_draws(kept_index, j) = theta[static_cast<std::size_t>(j)];
        result.log_target[kept_index] =
            log_posterior_unnormalised(theta, x, ssr.matrix(), M, prior, range, extension, psi_now());
        for (Eigen::Index j = 0; j < result.psi_draws.cols(); ++j) result.psi_draws(kept_index, j) = psi_now()[j];
        ++kept_index;
      }
    }
    report_latent_acc += sweep_acc;
    ++report_sweeps;
    const bool last = it + 1 == options.iterations;
    if (options.progress &&
        ((options.progress_every > 0 && (it + 1) % options.progress_every == 0) || last)) {
      BatchMcmcProgress p;
      p.iteration = it + 1;
      p.iterations = options.iterations;
      p.burning_in = it + 1 <= options.burn_in;
      p.latent_acceptance = report_latent_acc / static_cast<double>(report_sweeps);
      p.z_acceptance = report_z_tries > 0 ? report_z_acc / static_cast<double>(report_z_tries) : 0.0;
      p.seconds = seconds_since(start);
      options.progress(p);
      report_latent_acc = report_z_acc = 0.0;
      report_sweeps = report_z_tries = 0;
    }
  }

  // ---- summaries ----
  const double after = static_cast<double>(options.iterations - options.burn_in);
  result.latent_acceptance_per_truck = accepted_after_burn_in / after;
  result.latent_acceptance = options.freeze_latents ? 0.0 : result.latent_acceptance_per_truck.mean();
  result.latent_proposal_scale = log_scale.exp();
  result.z_acceptance =
      z_tried_after > 0 ? static_cast<double>(z_accepted_after) / static_cast<double>(z_tried_after) : 0.0;
  result.sigma_k_acceptance = sk_try > 0 ? static_cast<double>(sk_acc) / static_cast<double>(sk_try) : 1.0;
  if (extension_steps) {
    result.psi_acceptance = extension_steps->walk_acceptance();
    result.psi_jump_acceptance = extension_steps->jump_acceptance();
    if (stiffness_edited) result.sigma_k_acceptance = result.stiffness_acceptance = extension_steps->stiffness_acceptance();
  }
  result.sigma_kt_acceptance =
      skt_try > 0 ? static_cast<double>(skt_acc) / static_cast<double>(skt_try) : 1.0;
  result.sigma_if_acceptance =
      sif_try > 0 ? static_cast<double>(sif_acc) / static_cast<double>(sif_try) : 1.0;
  auto rate = [](const AncillaryUpdater& u) {
    return u.tried() > 0 ? static_cast<double>(u.accepted()) / static_cast<double>(u.tried()) : 0.0;
  };
  result.ancillary_k_acceptance = rate(ancillary_k);
  result.ancillary_kt_acceptance = rate(ancillary_kt);
  result.ancillary_z_acceptance = rate(ancillary_z);
  result.lateral_jump_acceptance = lateral_jump_counts.rate();
  result.joint_jump_acceptance = joint_jump_counts.rate();
  result.latent_mean.resize(N, kLatentCount);
  result.latent_sd.resize(N, kLatentCount);
  for (int n = 0; n < N; ++n) {
    const auto& mom = latent_posterior[static_cast<std::size_t>(n)];
    result.latent_mean.row(n) = mom.mean.transpose();
    result.latent_sd.row(n) = mom.covariance().diagonal().cwiseSqrt().transpose();
  }
  result.integrator_calls = evaluator.calls();
  result.integrator_passes = evaluator.passes();
  result.wall_seconds = seconds_since(start);
  return result;
}

}  // namespace ssrfleet::fleet
