#include "fleet/batch_mcmc.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>

#include <Eigen/Cholesky>
#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>

#include "fleet/batch_mcmc_interweave.hpp"
#include "fleet/batch_mcmc_residuals.hpp"
#include "model/fleet_conditionals.hpp"
#include "model/truck_table.hpp"
#include "smc/engine.hpp"
#include "model/truncated_samplers.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {

using detail::gather;
using detail::Observations;
using detail::ResidualEvaluator;

using Engine = boost::random::mt19937_64;
using Clock = std::chrono::steady_clock;
constexpr double kNegInf = -std::numeric_limits<double>::infinity();

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double log_uniform(Engine& engine) { return std::log(uniform_open01(engine)); }

double clip(double v, double lo, double hi) { return std::clamp(v, lo, hi); }

double column_sd(const Eigen::VectorXd& v) {
  if (v.size() < 2) return 0.0;
  return std::sqrt((v.array() - v.mean()).square().sum() / static_cast<double>(v.size() - 1));
}

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

#define SSRFLEET_OPTION_CHECK(cond, name, value, rule)                                       \
  do {                                                                                       \
    if (!(cond)) {                                                                           \
      if (error) {                                                                           \
        std::ostringstream os;                                                               \
        os << "BatchMcmcOptions: " << name << " is " << (value) << ", but must be " << rule; \
        *error = os.str();                                                                   \
      }                                                                                      \
      return false;                                                                          \
    }                                                                                        \
  } while (false)

bool BatchMcmcOptions::IsValid(std::string* error) const {
  SSRFLEET_OPTION_CHECK(iterations >= 1, "iterations", iterations, ">= 1");
  SSRFLEET_OPTION_CHECK(burn_in >= 0, "burn_in", burn_in, ">= 0");
  SSRFLEET_OPTION_CHECK(burn_in < iterations, "burn_in", burn_in,
                        "< iterations (" + std::to_string(iterations) + "), or no draw is kept");
  SSRFLEET_OPTION_CHECK(thin >= 1, "thin", thin, ">= 1");
  SSRFLEET_OPTION_CHECK(target_acceptance > 0.0 && target_acceptance < 1.0, "target_acceptance",
                        target_acceptance, "in (0, 1)");
  SSRFLEET_OPTION_CHECK(z_moves_per_sweep >= 1, "z_moves_per_sweep", z_moves_per_sweep, ">= 1");
  SSRFLEET_OPTION_CHECK(std::isfinite(init_grid_step_m) && init_grid_step_m > 0.0, "init_grid_step_m",
                        init_grid_step_m, "positive");
  SSRFLEET_OPTION_CHECK(hold_theta_sweeps >= 0, "hold_theta_sweeps", hold_theta_sweeps, ">= 0");
  SSRFLEET_OPTION_CHECK(progress_every >= 0, "progress_every", progress_every, ">= 0");
  for (int j = 0; j < kHyperCount; ++j) {
    const std::string name = "prior bounds of " + std::string(kHyperNames[static_cast<std::size_t>(j)]);
    std::ostringstream value;
    value << "[" << prior.lo[static_cast<std::size_t>(j)] << ", " << prior.hi[static_cast<std::size_t>(j)]
          << "]";
    SSRFLEET_OPTION_CHECK(std::isfinite(prior.lo[static_cast<std::size_t>(j)]) &&
                              std::isfinite(prior.hi[static_cast<std::size_t>(j)]) &&
                              prior.lo[static_cast<std::size_t>(j)] < prior.hi[static_cast<std::size_t>(j)],
                          name, value.str(), "a finite interval with lo < hi");
  }
  for (int j : {kSigmaK, kSigmaKt, kSigmaZ, kSigmaIf}) {
    const std::string name = "lower prior bound of " + std::string(kHyperNames[static_cast<std::size_t>(j)]);
    SSRFLEET_OPTION_CHECK(prior.lo[static_cast<std::size_t>(j)] > 0.0, name,
                          prior.lo[static_cast<std::size_t>(j)], "positive (a scale)");
  }
  if (initial_theta) {
    SSRFLEET_OPTION_CHECK(prior.contains(*initial_theta), "initial_theta", "(outside the prior box)",
                          "inside the prior box");
  }
  if (initial_latents) {
    SSRFLEET_OPTION_CHECK(initial_latents->cols() == kLatentCount, "initial_latents columns",
                          initial_latents->cols(), "3 (k, kt, z)");
    SSRFLEET_OPTION_CHECK(initial_latents->allFinite(), "initial_latents", "(not all finite)", "finite");
  }
  SSRFLEET_OPTION_CHECK(!freeze_latents || initial_latents.has_value(), "freeze_latents", "true",
                        "false unless initial_latents is given");
  SSRFLEET_OPTION_CHECK(ancillary_steps >= 1, "ancillary_steps", ancillary_steps, ">= 1");
  SSRFLEET_OPTION_CHECK(ancillary_every >= 1, "ancillary_every", ancillary_every, ">= 1");
  SSRFLEET_OPTION_CHECK(lateral_jump_every >= 0, "lateral_jump_every", lateral_jump_every, ">= 0");
  SSRFLEET_OPTION_CHECK(threads >= 0, "threads", threads, ">= 0 (0 = all hardware threads)");
  return true;
}

#undef SSRFLEET_OPTION_CHECK

double log_posterior_unnormalised(const HyperVector& theta, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                                  const Eigen::Ref<const Eigen::VectorXd>& ssr, int sensors,
                                  const PriorBounds& prior, const LateralRange& range) {
  double lp = prior.log_prior(theta);
  if (!std::isfinite(lp)) return kNegInf;
  for (Eigen::Index n = 0; n < latents.rows(); ++n) {
    lp += log_latent_density(latents(n, kStiffness), latents(n, kTyreStiffness), latents(n, kLateral), theta,
                             range);
    lp += log_likelihood_from_ssr(ssr[n], sensors, theta[kSigmaIf]);
  }
  return lp;
}

BatchMcmcResult run_batch_mcmc(const site::Site& site, const std::vector<records::WimRecord>& records,
                               const BatchMcmcOptions& options) {
  const Clock::time_point start = Clock::now();
  std::string error;
  if (!options.IsValid(&error)) throw UsageError(error);
  const Observations obs = gather(site, records);
  const int N = obs.trucks, M = obs.sensors;
  const PriorBounds& prior = options.prior;
  const LateralRange range{site.lateral_min_m(), site.lateral_max_m()};
  if (options.initial_latents && options.initial_latents->rows() != N) {
    throw UsageError("BatchMcmcOptions: initial_latents has " +
                     std::to_string(options.initial_latents->rows()) + " rows, but there are " +
                     std::to_string(N) + " trucks");
  }

  Engine engine(options.seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  ResidualEvaluator evaluator(site, obs, threads);

  BatchMcmcResult result;
  result.threads = threads;
  result.iterations = options.iterations;
  result.burn_in = options.burn_in;
  result.truck_ids.reserve(records.size());
  for (const auto& r : records) result.truck_ids.push_back(r.truck_id);

  // ---- initialisation ----
  auto box_centre = [&](int j) {
    return std::sqrt(prior.lo[static_cast<std::size_t>(j)] * prior.hi[static_cast<std::size_t>(j)]);
  };
  auto clip_to_box = [&](int j, double v) {
    return clip(v, prior.lo[static_cast<std::size_t>(j)], prior.hi[static_cast<std::size_t>(j)]);
  };
  Eigen::MatrixXd x(N, kLatentCount);  // latents, one row per truck
  Eigen::ArrayXd ssr(N);
  std::vector<int> all(static_cast<std::size_t>(N));
  for (int n = 0; n < N; ++n) all[static_cast<std::size_t>(n)] = n;
  const double k0 = options.initial_theta ? (*options.initial_theta)[kK] : box_centre(kK);
  const double kt0 = options.initial_theta ? (*options.initial_theta)[kKt] : box_centre(kKt);
  if (options.initial_latents) {
    x = *options.initial_latents;
    for (int n = 0; n < N; ++n) {
      if (!(x(n, kStiffness) > 0.0 && x(n, kTyreStiffness) > 0.0 && x(n, kLateral) >= range.lo_m &&
            x(n, kLateral) <= range.hi_m)) {
        throw UsageError("BatchMcmcOptions: initial_latents row " + std::to_string(n) +
                         " has a non-positive stiffness or a lateral position off the road");
      }
    }
    evaluator.evaluate(all, x.col(kStiffness).array(), x.col(kTyreStiffness).array(), x.col(kLateral).array(),
                       ssr);
  } else if (options.init == BatchMcmcOptions::Init::kBestFit) {
    // Every truck at its own best fit (independent per truck, so the threads change no bit).
    model::TruckTableOptions search;
    search.k_start_npm = k0;
    search.kt_start_npm = kt0;
    const smc::ParallelFor fits(options.threads > 0 ? options.threads : smc::TemperedSampler::Options::default_threads());
    std::vector<int> fit_passes(static_cast<std::size_t>(N), 0);
    fits(N, [&](Eigen::Index begin, Eigen::Index end) {
      for (Eigen::Index n = begin; n < end; ++n) {
        const auto& r = records[static_cast<std::size_t>(n)];
        const model::TruckFit f = model::fit_truck(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, search);
        x(n, kStiffness) = f.stiffness_npm;
        x(n, kTyreStiffness) = f.tyre_stiffness_npm;
        x(n, kLateral) = std::clamp(f.lateral_m, range.lo_m, range.hi_m);
        fit_passes[static_cast<std::size_t>(n)] = f.passes;
      }
    });
    for (int p : fit_passes) result.integrator_passes += p;
    evaluator.evaluate(all, x.col(kStiffness).array(), x.col(kTyreStiffness).array(), x.col(kLateral).array(), ssr);
  } else {
    // Coarse grid search over z with k, kt at generic values (see the header).
    std::vector<double> grid;
    for (int g = 0;; ++g) {
      const double z = range.lo_m + g * options.init_grid_step_m;
      if (z > range.hi_m + 1e-9) break;
      grid.push_back(std::min(z, range.hi_m));
    }
    const auto G = static_cast<Eigen::Index>(grid.size());
    std::vector<int> which;
    which.reserve(static_cast<std::size_t>(N * G));
    Eigen::ArrayXd k_grid(N * G), kt_grid(N * G), z_grid(N * G);
    for (int n = 0; n < N; ++n) {
      for (Eigen::Index g = 0; g < G; ++g) {
        const Eigen::Index i = n * G + g;
        which.push_back(n);
        k_grid[i] = k0;
        kt_grid[i] = kt0;
        z_grid[i] = grid[static_cast<std::size_t>(g)];
      }
    }
    Eigen::ArrayXd ssr_grid;
    evaluator.evaluate(which, k_grid, kt_grid, z_grid, ssr_grid);
    for (int n = 0; n < N; ++n) {
      Eigen::Index best = 0;
      ssr_grid.segment(n * G, G).minCoeff(&best);
      x(n, kStiffness) = k0;
      x(n, kTyreStiffness) = kt0;
      x(n, kLateral) = grid[static_cast<std::size_t>(best)];
      ssr[n] = ssr_grid[n * G + best];
    }
  }
  result.init_seconds = seconds_since(start);

  HyperVector theta{};
  if (options.initial_theta) {
    theta = *options.initial_theta;
  } else {
    const Eigen::VectorXd z = x.col(kLateral);
    // Latents that come from the data (given, or each truck's best fit) set θ's start too.
    const bool from_data = options.initial_latents || options.init == BatchMcmcOptions::Init::kBestFit;
    theta[kK] = clip_to_box(kK, from_data ? x.col(kStiffness).mean() : k0);
    theta[kKt] = clip_to_box(kKt, from_data ? x.col(kTyreStiffness).mean() : kt0);
    const double sk = from_data && N > 2 ? column_sd(x.col(kStiffness)) : 0.2 * theta[kK];
    const double skt = from_data && N > 2 ? column_sd(x.col(kTyreStiffness)) : 0.2 * theta[kKt];
    theta[kSigmaK] = clip_to_box(kSigmaK, sk);
    theta[kSigmaKt] = clip_to_box(kSigmaKt, skt);
    theta[kZ] = clip_to_box(kZ, z.mean());
    theta[kSigmaZ] = clip_to_box(kSigmaZ, N > 2 ? column_sd(z) : 0.5);
    theta[kSigmaIf] = clip_to_box(kSigmaIf, std::sqrt(ssr.sum() / (static_cast<double>(N) * M)));
  }
  result.initial_theta = theta;
  result.initial_latents = x;

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
  Eigen::ArrayXd k_jump(N), kt_jump(N), z_jump(N), ssr_jump(N);
  long long lateral_jumps_accepted = 0, lateral_jumps_tried = 0;
  std::vector<int> all_trucks(static_cast<std::size_t>(N));  // a lateral jump proposes for every truck
  for (int n = 0; n < N; ++n) all_trucks[static_cast<std::size_t>(n)] = n;

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
      evaluator.evaluate(all, k, kt, z, ssr_out);
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
      if (V > 0) evaluator.evaluate(valid, k_prop, kt_prop, z_prop, ssr_prop);
      const double inv2var_if = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
      Eigen::ArrayXd accept_prob = Eigen::ArrayXd::Zero(N);
      for (Eigen::Index i = 0; i < V; ++i) {
        const int n = valid[static_cast<std::size_t>(i)];
        // The truncation normaliser of z depends on theta only and cancels here.
        const double log_alpha =
            -(ssr_prop[i] - ssr[n]) * inv2var_if +
            log_normal_density(proposal(n, kStiffness), theta[kK], theta[kSigmaK]) -
            log_normal_density(x(n, kStiffness), theta[kK], theta[kSigmaK]) +
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

      // Lateral jumps: z' from the prior on the road, (k, k_t) kept; the prior cancels against the
      // proposal, so the likelihood ratio decides.
      if (options.lateral_jump_every > 0 && it % options.lateral_jump_every == 0) {
        for (int n = 0; n < N; ++n) {
          k_jump[n] = x(n, kStiffness);
          kt_jump[n] = x(n, kTyreStiffness);
          z_jump[n] = draw_truncated_normal(engine, theta[kZ], theta[kSigmaZ], range.lo_m, range.hi_m);
        }
        evaluator.evaluate(all_trucks, k_jump, kt_jump, z_jump, ssr_jump);
        const double inv2var = 0.5 / (theta[kSigmaIf] * theta[kSigmaIf]);
        for (int n = 0; n < N; ++n) {
          const double log_alpha = -(ssr_jump[n] - ssr[n]) * inv2var;
          if (log_uniform(engine) < log_alpha) {
            x(n, kLateral) = z_jump[n];
            ssr[n] = ssr_jump[n];
            if (!burning_in) ++lateral_jumps_accepted;
          }
        }
        if (!burning_in) lateral_jumps_tried += N;
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
      mean_and_scale(x.col(kStiffness), kK, kSigmaK, sk_acc, sk_try);
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
    }

    // ---- record ----
    if (!burning_in) {
      for (int n = 0; n < N; ++n) latent_posterior[static_cast<std::size_t>(n)].add(x.row(n).transpose());
      if ((it - options.burn_in) % options.thin == 0) {
        for (int j = 0; j < kHyperCount; ++j)
          result.theta_draws(kept_index, j) = theta[static_cast<std::size_t>(j)];
        result.log_target[kept_index] = log_posterior_unnormalised(theta, x, ssr.matrix(), M, prior, range);
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
  result.lateral_jump_acceptance =
      lateral_jumps_tried > 0 ? static_cast<double>(lateral_jumps_accepted) / static_cast<double>(lateral_jumps_tried) : 0.0;
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
