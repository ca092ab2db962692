#include "fleet/posterior_predictive_draws.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <boost/random/mersenne_twister.hpp>

#include "fleet/predictive_trucks.hpp"
#include "model/fleet_model.hpp"
#include "model/truncated_samplers.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

PosteriorPredictiveDraws posterior_predictive_draws(const site::Site& site, const PosteriorCloud& cloud,
                                                    const EqualWeightDraws& draws,
                                                    const std::vector<records::WimRecord>& observed,
                                                    Eigen::Index max_draws, Eigen::Index max_trucks,
                                                    std::uint64_t seed) {
  if (max_draws < 1 || max_trucks < 1)
    throw std::invalid_argument("posterior_predictive_draws(): cap below 1");
  PosteriorPredictiveDraws out;
  const Eigen::Index n = std::min(max_draws, draws.draws);
  for (Eigen::Index i = 0; i < n; ++i) {
    out.draw_index.push_back(static_cast<Eigen::Index>((static_cast<double>(i) + 0.5) * draws.draws / n));
  }
  out.trucks = std::min<Eigen::Index>(max_trucks, static_cast<Eigen::Index>(observed.size()));
  const Eigen::Index R = draws.chains * n, T = out.trucks;
  out.impact_factor.resize(R * T, site.sensors());
  if (R * T == 0) return out;

  const ModelSpec model = posterior_model(cloud, site);
  const ModelExtension* extension = model.extension.get();
  const bool own_stiffness = extension != nullptr && extension->edits_stiffness_distribution();
  const double inf = std::numeric_limits<double>::infinity();
  const double zlo = cloud.lateral_min_m, zhi = cloud.lateral_max_m;
  boost::random::mt19937_64 engine(seed);
  PredictiveTrucks drawn;
  drawn.theta_draws = static_cast<int>(R);
  drawn.trucks_per_draw = static_cast<int>(T);
  drawn.sigma_if.resize(R);
  drawn.trucks.resize(R * T);
  for (Eigen::Index r = 0; r < R; ++r) {
    const Eigen::Index column = (r / n) * draws.draws + out.draw_index[static_cast<std::size_t>(r % n)];
    const Eigen::Index p = draws.source[static_cast<std::size_t>(column)];  // the cloud column: its psi
    drawn.theta_index.push_back(p);
    const auto th = [&](int j) { return draws.theta(j, column); };
    drawn.sigma_if[r] = th(kSigmaIf);
    if (log_normal_mass(zlo, zhi, th(kZ), th(kSigmaZ)) < std::log(1e-6)) {
      throw UsageError("the fleet's lateral distribution N(" + std::to_string(th(kZ)) + ", " +
                       std::to_string(th(kSigmaZ)) + "^2) of a draw misses this road's surface");
    }
    for (Eigen::Index t = 0; t < T; ++t) {
      const Eigen::Index b = r * T + t;
      const auto& truck = observed[static_cast<std::size_t>(t)];
      drawn.trucks.speed_mps[b] = truck.speed_mps;
      drawn.trucks.sprung_mass_kg[b] = truck.sprung_mass_kg;
      double mean = th(kK), sd = th(kSigmaK);
      if (own_stiffness) {
        // A class of the model's stiffness mixture by its weight, then that class's normal.
        const auto mixture = extension->stiffness_mixture(cloud.psi.col(p).data(), th(kK), th(kSigmaK));
        const double pick = uniform_open01(engine);
        double below = 0.0;
        std::size_t c = 0;
        while (c + 1 < mixture.size() && pick >= below + mixture[c].weight) below += mixture[c++].weight;
        mean = mixture[c].mean_npm;
        sd = mixture[c].sd_npm;
      }
      drawn.trucks.stiffness_npm[b] = truncated_normal_quantile(uniform_open01(engine), mean, sd, 0.0, inf);
      drawn.trucks.tyre_stiffness_npm[b] =
          truncated_normal_quantile(uniform_open01(engine), th(kKt), th(kSigmaKt), 0.0, inf);
      drawn.trucks.lateral_m[b] =
          truncated_normal_quantile(uniform_open01(engine), th(kZ), th(kSigmaZ), zlo, zhi);
    }
  }
  Eigen::ArrayXXd clean(site.sensors(), R * T);
  simulate_predictive_trucks(site, nullptr, cloud, drawn, extension, clean);
  // The measurement noise: a standard normal by inversion of a uniform, so the bits do not depend
  // on a library's normal sampler.
  for (Eigen::Index b = 0; b < R * T; ++b) {
    for (Eigen::Index s = 0; s < site.sensors(); ++s) {
      const double z = truncated_normal_quantile(uniform_open01(engine), 0.0, 1.0, -inf, inf);
      out.impact_factor(b, s) = clean(s, b) + drawn.sigma_if[b / T] * z;
    }
  }
  return out;
}

}  // namespace ssrfleet::fleet
