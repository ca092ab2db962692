#include "fleet/batch_mcmc_start.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>

#include "model/truck_table.hpp"
#include "smc/engine.hpp"
#include "util/errors.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::fleet::detail {

namespace {
double column_sd(const Eigen::VectorXd& v) {
  if (v.size() < 2) return 0.0;
  return std::sqrt((v.array() - v.mean()).square().sum() / static_cast<double>(v.size() - 1));
}
}  // namespace

ChainStart start_chain(const site::Site& site, const std::vector<records::WimRecord>& records,
                       const BatchMcmcOptions& options, const Observations& obs, ResidualEvaluator& evaluator,
                       const double* psi) {
  const int N = obs.trucks, M = obs.sensors;
  const PriorBounds& prior = options.prior;
  const LateralRange range{site.lateral_min_m(), site.lateral_max_m()};
  if (options.initial_latents && options.initial_latents->rows() != N) {
    throw UsageError("BatchMcmcOptions: initial_latents has " +
                     std::to_string(options.initial_latents->rows()) + " rows, but there are " +
                     std::to_string(N) + " trucks");
  }
  auto box_centre = [&](int j) {
    return std::sqrt(prior.lo[static_cast<std::size_t>(j)] * prior.hi[static_cast<std::size_t>(j)]);
  };
  auto clip_to_box = [&](int j, double v) {
    return std::clamp(v, prior.lo[static_cast<std::size_t>(j)], prior.hi[static_cast<std::size_t>(j)]);
  };
  ChainStart s;
  Eigen::MatrixXd& x = s.latents;  // one row per truck
  Eigen::ArrayXd& ssr = s.ssr;
  x.resize(N, kLatentCount);
  ssr.resize(N);
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
                       psi, ssr);
  } else if (options.init == BatchMcmcOptions::Init::kBestFit) {
    // Every truck at its own best fit (independent per truck, so the threads change no bit).
    model::TruckTableOptions search;
    search.k_start_npm = k0;
    search.kt_start_npm = kt0;
    const smc::ParallelFor fits(options.threads > 0 ? options.threads : smc::TemperedSampler::Options::default_threads());
    std::vector<int> fit_passes(static_cast<std::size_t>(N), 0);
    const util::StopCheck stop_check;  // the driver's stop token (util/stop_token.hpp), seen by the workers
    fits(N, [&](Eigen::Index begin, Eigen::Index end) {
      for (Eigen::Index n = begin; n < end; ++n) {
        stop_check();
        const auto& r = records[static_cast<std::size_t>(n)];
        const model::TruckFit f = model::fit_truck(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, search);
        x(n, kStiffness) = f.stiffness_npm;
        x(n, kTyreStiffness) = f.tyre_stiffness_npm;
        x(n, kLateral) = std::clamp(f.lateral_m, range.lo_m, range.hi_m);
        fit_passes[static_cast<std::size_t>(n)] = f.passes;
      }
    });
    for (int p : fit_passes) s.fit_passes += p;
    evaluator.evaluate(all, x.col(kStiffness).array(), x.col(kTyreStiffness).array(), x.col(kLateral).array(), psi, ssr);
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
    evaluator.evaluate(which, k_grid, kt_grid, z_grid, psi, ssr_grid);
    for (int n = 0; n < N; ++n) {
      Eigen::Index best = 0;
      ssr_grid.segment(n * G, G).minCoeff(&best);
      x(n, kStiffness) = k0;
      x(n, kTyreStiffness) = kt0;
      x(n, kLateral) = grid[static_cast<std::size_t>(best)];
      ssr[n] = ssr_grid[n * G + best];
    }
  }
  HyperVector& theta = s.theta;
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
    if (options.start_dispersion > 0.0) {
      // A generator of its own (not the chain's), so the chain's stream is the same with or without.
      boost::random::mt19937_64 engine(options.seed ^ 0x6f76657264697370ULL);
      boost::random::normal_distribution<double> normal;
      const double d = options.start_dispersion, root_n = std::sqrt(static_cast<double>(std::max<Eigen::Index>(N, 1)));
      const std::pair<int, int> located[] = {{kK, kSigmaK}, {kKt, kSigmaKt}, {kZ, kSigmaZ}};
      for (const auto& [mean, sd] : located) theta[mean] = clip_to_box(mean, theta[mean] + 2.0 * d * theta[sd] / root_n * normal(engine));
      for (const int sd : {kSigmaK, kSigmaKt, kSigmaZ, kSigmaIf}) theta[sd] = clip_to_box(sd, theta[sd] * std::exp(0.5 * d * normal(engine)));
    }
  }
  return s;
}

}  // namespace ssrfleet::fleet::detail
