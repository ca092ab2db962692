#include "fleet/predictive_trucks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <boost/random/uniform_01.hpp>
#include <boost/random/uniform_int_distribution.hpp>

#include "model/extended_forward.hpp"
#include "model/fleet_model.hpp"
#include "model/truncated_samplers.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
// Indices drawn in proportion to weight (systematic: low variance, deterministic given u).
std::vector<Eigen::Index> draw_by_weight(const Eigen::ArrayXd& w, int n, double u) {
  std::vector<Eigen::Index> idx;
  idx.reserve(static_cast<std::size_t>(n));
  const double total = w.sum();
  double cum = w[0] / total;
  Eigen::Index j = 0;
  for (int s = 0; s < n; ++s) {
    const double target = (s + u) / n;
    while (target > cum && j + 1 < w.size()) cum += w[++j] / total;
    idx.push_back(j);
  }
  return idx;
}

// T uniforms, one in each stratum [t/T, (t+1)/T), in random order: one axis of a Latin
// hypercube. Each value is still uniform on (0, 1) (so every simulated truck keeps its exact
// distribution), but the T values together cover the axis evenly. The shuffle is a hand-written
// Fisher-Yates on boost's portable distribution, so the order is the same on every platform.
std::vector<double> stratified_uniforms(boost::random::mt19937_64& engine, int T) {
  std::vector<double> u(static_cast<std::size_t>(T));
  for (int t = 0; t < T; ++t) u[static_cast<std::size_t>(t)] = (t + uniform_open01(engine)) / T;
  for (int t = T - 1; t > 0; --t) {
    boost::random::uniform_int_distribution<int> pick(0, t);
    std::swap(u[static_cast<std::size_t>(t)], u[static_cast<std::size_t>(pick(engine))]);
  }
  return u;
}
}  // namespace

PredictiveTrucks draw_predictive_trucks(const PosteriorCloud& posterior, double zlo, double zhi, int R, int T,
                                        const PredictiveTraffic& traffic, boost::random::mt19937_64& engine,
                                        const ModelExtension* model) {
  const bool own_stiffness = model != nullptr && model->edits_stiffness_distribution();
  if (own_stiffness && (posterior.psi.rows() != model->dim() || posterior.psi.cols() != posterior.theta.cols())) {
    throw UsageError("the posterior's draws of " + model->name() + "'s parameters do not match the model");
  }
  // Each truck's class under the model's stiffness distribution comes from an engine of its own,
  // seeded from a copy of `engine` (which it leaves as it is), so the base model's draws stay the
  // same with or without a model.
  boost::random::mt19937_64 class_engine = engine;
  class_engine.seed(class_engine() ^ 0x5bd1e995u);
  if (posterior.theta.rows() != kHyperCount || posterior.theta.cols() < 1 ||
      posterior.weights.size() != posterior.theta.cols() || (posterior.speed_mps.empty() && !traffic.fixed())) {
    throw UsageError("the posterior holds no usable draws");
  }
  if (traffic.speed_mps.has_value() != traffic.sprung_mass_kg.has_value()) {
    throw std::invalid_argument("draw_predictive_trucks: a fixed truck needs both its speed and its sprung mass");
  }
  boost::random::uniform_01<double> unif;
  PredictiveTrucks out;
  out.theta_draws = R;
  out.trucks_per_draw = T;
  out.theta_index = draw_by_weight(posterior.weights, R, unif(engine));
  out.sigma_if.resize(R);
  out.trucks.resize(static_cast<Eigen::Index>(R) * T);
  const std::size_t n_obs = posterior.speed_mps.size();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> traffic_cdf;  // cumulative bootstrap weights of the observed trucks
  for (int r = 0; r < R; ++r) {
    const Eigen::Index p = out.theta_index[static_cast<std::size_t>(r)];
    const auto th = [&](int j) { return posterior.theta(j, p); };
    out.sigma_if[r] = th(kSigmaIf);
    if (log_normal_mass(zlo, zhi, th(kZ), th(kSigmaZ)) < std::log(1e-6)) {
      throw UsageError("the fleet's lateral distribution N(" + std::to_string(th(kZ)) + ", " +
                       std::to_string(th(kSigmaZ)) + "^2) misses this road's surface [" + std::to_string(zlo) + ", " +
                       std::to_string(zhi) + "] m");
    }
    // The traffic (v, m2) is known only through the observed trucks: each θ draw weighs them by
    // a Bayesian bootstrap, so a band of the mean also carries the uncertainty of a traffic mix
    // seen in, say, 100 trucks. The weights average to equal, so means and limits are unchanged
    // in expectation.
    double total = 0.0;
    if (!traffic.fixed()) {
      traffic_cdf.resize(n_obs);
      for (std::size_t i = 0; i < n_obs; ++i) {
        traffic_cdf[i] = total += traffic.bootstrap ? -std::log(uniform_open01(engine)) : 1.0;
      }
    }
    const auto u_obs = stratified_uniforms(engine, T), u_k = stratified_uniforms(engine, T),
               u_kt = stratified_uniforms(engine, T), u_z = stratified_uniforms(engine, T);
    for (int t = 0; t < T; ++t) {
      const auto i = static_cast<std::size_t>(t);
      const Eigen::Index b = static_cast<Eigen::Index>(r) * T + t;
      if (traffic.fixed()) {
        out.trucks.speed_mps[b] = *traffic.speed_mps;
        out.trucks.sprung_mass_kg[b] = *traffic.sprung_mass_kg;
      } else {
        const auto obs = std::min<std::size_t>(
            n_obs - 1, std::upper_bound(traffic_cdf.begin(), traffic_cdf.end(), u_obs[i] * total) - traffic_cdf.begin());
        out.trucks.speed_mps[b] = posterior.speed_mps[obs];
        out.trucks.sprung_mass_kg[b] = posterior.sprung_mass_kg[obs];
      }
      if (own_stiffness) {
        // The model's distribution as a mixture of normals: a class by its own uniform, then its
        // normal from the same stratified uniform as the base model's, truncated at zero like it (a
        // class the data barely constrain, e.g. a second class of a small share, can reach below).
        const auto mixture = model->stiffness_mixture(posterior.psi.col(p).data(), th(kK), th(kSigmaK));
        const double pick = uniform_open01(class_engine);
        double below = 0.0;
        std::size_t c = 0;
        while (c + 1 < mixture.size() && pick >= below + mixture[c].weight) below += mixture[c++].weight;
        out.trucks.stiffness_npm[b] = truncated_normal_quantile(u_k[i], mixture[c].mean_npm, mixture[c].sd_npm, 0.0, inf);
      } else {
        out.trucks.stiffness_npm[b] = truncated_normal_quantile(u_k[i], th(kK), th(kSigmaK), 0.0, inf);
      }
      out.trucks.tyre_stiffness_npm[b] = truncated_normal_quantile(u_kt[i], th(kKt), th(kSigmaKt), 0.0, inf);
      out.trucks.lateral_m[b] = truncated_normal_quantile(u_z[i], th(kZ), th(kSigmaZ), zlo, zhi);
    }
  }
  return out;
}

ModelSpec posterior_model(const PosteriorCloud& posterior, const site::Site& site) {
  ModelSpec model;
  if (posterior.model == "base") return model;
  try {
    model = parse_model_spec(posterior.model, site);
  } catch (const UsageError& e) {
    throw UsageError(std::string("the posterior's model cannot be rebuilt on this site: ") + e.what());
  }
  if (model.extension->dim() != posterior.psi.rows() ||
      (posterior.psi.rows() > 0 && posterior.psi.cols() != posterior.theta.cols())) {
    throw UsageError("the posterior's model '" + posterior.model + "' has " + std::to_string(model.extension->dim()) +
                     " free parameters, its draws " + std::to_string(posterior.psi.rows()) + " rows of psi for " +
                     std::to_string(posterior.psi.cols()) + " of " + std::to_string(posterior.theta.cols()) + " draws");
  }
  return model;
}

void simulate_predictive_trucks(const site::Site& site, const vehicle::PassIntegrator* integrator,
                                const PosteriorCloud& posterior, const PredictiveTrucks& drawn,
                                const ModelExtension* extension, Eigen::Ref<Eigen::ArrayXXd> if_out) {
  const site::TruckBatch& batch = drawn.trucks;
  if (extension == nullptr || !extension->edits_forward()) {
    if (integrator != nullptr) {
      site.impact_factors_at(*integrator, batch, if_out);
    } else {
      site.impact_factors(batch, if_out);
    }
    return;
  }
  const int T = drawn.trucks_per_draw;
  std::vector<ExtendedPass> passes(static_cast<std::size_t>(batch.size()));
  for (Eigen::Index b = 0; b < batch.size(); ++b) {
    auto& pass = passes[static_cast<std::size_t>(b)];
    pass.setup = base_pass(site, batch.speed_mps[b], batch.sprung_mass_kg[b], batch.stiffness_npm[b],
                           batch.tyre_stiffness_npm[b], batch.lateral_m[b]);
    // Every truck of one θ draw shares its ψ (and so its added profile); none when the spec fixes
    // every parameter.
    const Eigen::Index p = drawn.theta_index[static_cast<std::size_t>(b / T)];
    pass.psi = posterior.psi.rows() > 0 ? posterior.psi.col(p).data() : nullptr;
  }
  simulate_passes(site, extension, passes, if_out, nullptr, integrator);
}

}  // namespace ssrfleet::fleet
