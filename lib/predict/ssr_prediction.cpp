#include "predict/ssr_prediction.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_01.hpp>
#include <boost/random/uniform_int_distribution.hpp>

#include "model/extended_forward.hpp"
#include "model/fleet_model.hpp"
#include "model/model_spec.hpp"
#include "model/truncated_samplers.hpp"
#include "predict/physical_effects.hpp"
#include "util/errors.hpp"
#include "util/quantile.hpp"

namespace ssrfleet::predict {

using fleet::HyperVector;

void PredictionOptions::validate() const {
  if (theta_draws < 2) throw UsageError("predict: theta draws is " + std::to_string(theta_draws) + ", but must be >= 2");
  if (trucks_per_draw < 1) {
    throw UsageError("predict: trucks per draw is " + std::to_string(trucks_per_draw) + ", but must be >= 1");
  }
}

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
template <class Engine>
std::vector<double> stratified_uniforms(Engine& engine, int T) {
  std::vector<double> u(static_cast<std::size_t>(T));
  for (int t = 0; t < T; ++t) u[static_cast<std::size_t>(t)] = (t + fleet::uniform_open01(engine)) / T;
  for (int t = T - 1; t > 0; --t) {
    boost::random::uniform_int_distribution<int> pick(0, t);
    std::swap(u[static_cast<std::size_t>(t)], u[static_cast<std::size_t>(pick(engine))]);
  }
  return u;
}
}  // namespace

SsrPrediction predict_ssr(const fleet::PosteriorCloud& posterior, const site::Site& site,
                          std::vector<double> positions_m, const PredictionOptions& options) {
  options.validate();
  if (posterior.theta.rows() != fleet::kHyperCount || posterior.theta.cols() < 1 ||
      posterior.weights.size() != posterior.theta.cols() || posterior.speed_mps.empty()) {
    throw UsageError("predict: the posterior holds no usable draws");
  }
  // The fitted model's effects, rebuilt for this site from the posterior's spec; the force the
  // road feels keeps only some of them (physical_effects.hpp).
  fleet::ModelSpec model;
  if (posterior.model != "base") {
    try {
      model = fleet::parse_model_spec(posterior.model, site);
    } catch (const UsageError& e) {
      throw UsageError(std::string("predict: the posterior's model cannot be rebuilt on this site: ") + e.what());
    }
    if (model.extension->dim() != posterior.psi.rows() ||
        (posterior.psi.rows() > 0 && posterior.psi.cols() != posterior.theta.cols())) {
      throw UsageError("predict: the posterior's model '" + posterior.model + "' has " +
                       std::to_string(model.extension->dim()) + " free parameters, its draws " +
                       std::to_string(posterior.psi.rows()) + " rows of psi for " +
                       std::to_string(posterior.psi.cols()) + " of " + std::to_string(posterior.theta.cols()) + " draws");
    }
  }
  // The draw's ψ (none when the spec fixes every parameter).
  const auto psi_of = [&](Eigen::Index draw) -> const double* {
    return posterior.psi.rows() > 0 ? posterior.psi.col(draw).data() : nullptr;
  };
  std::unique_ptr<PhysicalEffects> effects;
  if (model.extension) effects = std::make_unique<PhysicalEffects>(*model.extension, posterior.site_fingerprint == site.fingerprint());
  if (positions_m.empty()) positions_m = site.sensor_positions_m();
  const vehicle::PassIntegrator integrator(site.surface().dx_m, site.surface().samples(), positions_m);
  const auto n_pos = static_cast<Eigen::Index>(positions_m.size());
  const int R = options.theta_draws, T = options.trucks_per_draw;

  boost::random::mt19937_64 engine(options.seed);
  // The class of each truck under an extension's stiffness distribution comes from an engine of
  // its own, so the base model's draws (and the noise) stay those of a prediction without it.
  boost::random::mt19937_64 class_engine(options.seed ^ 0x5bd1e995u);
  boost::random::uniform_01<double> unif;
  boost::random::normal_distribution<double> std_normal(0.0, 1.0);
  const auto thetas = draw_by_weight(posterior.weights, R, unif(engine));
  const std::size_t n_obs = posterior.speed_mps.size();
  const double zlo = site.lateral_min_m(), zhi = site.lateral_max_m();

  site::TruckBatch batch;
  batch.resize(static_cast<Eigen::Index>(R) * T);
  Eigen::ArrayXd sigma_if(R);
  std::vector<double> traffic_cdf;  // cumulative bootstrap weights of the observed trucks
  for (int r = 0; r < R; ++r) {
    const Eigen::Index p = thetas[static_cast<std::size_t>(r)];
    const auto th = [&](int j) { return posterior.theta(j, p); };
    sigma_if[r] = th(fleet::kSigmaIf);
    if (fleet::log_normal_mass(zlo, zhi, th(fleet::kZ), th(fleet::kSigmaZ)) < std::log(1e-6)) {
      throw UsageError("predict: the fleet's lateral distribution N(" + std::to_string(th(fleet::kZ)) + ", " +
                       std::to_string(th(fleet::kSigmaZ)) + "^2) misses this road's surface [" + std::to_string(zlo) +
                       ", " + std::to_string(zhi) + "] m");
    }
    // The traffic (v, m2) is known only through the observed trucks: each θ draw weighs them by
    // a Bayesian bootstrap (Dirichlet(1, ..., 1) weights, Rubin 1981), so the band of the mean
    // also carries the uncertainty of a traffic mix seen in, say, 100 trucks. The weights
    // average to equal, so the mean and the limits are unchanged in expectation.
    traffic_cdf.resize(n_obs);
    double total = 0.0;
    for (std::size_t i = 0; i < n_obs; ++i) {
      traffic_cdf[i] = total += options.traffic_bootstrap ? -std::log(fleet::uniform_open01(engine)) : 1.0;
    }
    // The T trucks of one θ draw form a Latin hypercube over (observed truck, k, k_t, z). With
    // independent draws the per-θ mean pattern carries Monte Carlo noise of about s/√T (s the
    // truck-to-truck spread of the IF: 0.01 on AS3 at T = 100), which the band of the mean
    // would report as posterior uncertainty; stratifying removes most of it at no extra passes.
    const auto u_obs = stratified_uniforms(engine, T), u_k = stratified_uniforms(engine, T),
               u_kt = stratified_uniforms(engine, T), u_z = stratified_uniforms(engine, T);
    const double inf = std::numeric_limits<double>::infinity();
    for (int t = 0; t < T; ++t) {
      const auto i = static_cast<std::size_t>(t);
      const Eigen::Index b = static_cast<Eigen::Index>(r) * T + t;
      const auto obs = std::min<std::size_t>(
          n_obs - 1, std::upper_bound(traffic_cdf.begin(), traffic_cdf.end(), u_obs[i] * total) - traffic_cdf.begin());
      batch.speed_mps[b] = posterior.speed_mps[obs];
      batch.sprung_mass_kg[b] = posterior.sprung_mass_kg[obs];
      if (effects && effects->edits_stiffness_distribution()) {
        // The extension's distribution from the same stratified uniform (its class from its own).
        const double z = fleet::truncated_normal_quantile(u_k[i], 0.0, 1.0, -inf, inf);
        batch.stiffness_npm[b] = effects->draw_stiffness(psi_of(p), th(fleet::kK), th(fleet::kSigmaK),
                                                         fleet::uniform_open01(class_engine), z);
      } else {
        batch.stiffness_npm[b] = fleet::truncated_normal_quantile(u_k[i], th(fleet::kK), th(fleet::kSigmaK), 0.0, inf);
      }
      batch.tyre_stiffness_npm[b] = fleet::truncated_normal_quantile(u_kt[i], th(fleet::kKt), th(fleet::kSigmaKt), 0.0, inf);
      batch.lateral_m[b] = fleet::truncated_normal_quantile(u_z[i], th(fleet::kZ), th(fleet::kSigmaZ), zlo, zhi);
    }
  }
  Eigen::ArrayXXd model_if(n_pos, batch.size());
  if (effects && effects->edits_forward()) {
    std::vector<fleet::ExtendedPass> passes(static_cast<std::size_t>(batch.size()));
    for (Eigen::Index b = 0; b < batch.size(); ++b) {
      auto& pass = passes[static_cast<std::size_t>(b)];
      pass.setup = fleet::base_pass(site, batch.speed_mps[b], batch.sprung_mass_kg[b], batch.stiffness_npm[b],
                                    batch.tyre_stiffness_npm[b], batch.lateral_m[b]);
      pass.psi = psi_of(thetas[static_cast<std::size_t>(b / T)]);
    }
    fleet::simulate_passes(site, effects.get(), passes, model_if, nullptr, &integrator);
  } else {
    site.impact_factors_at(integrator, batch, model_if);
  }

  SsrPrediction out;
  out.position_m = positions_m;
  out.mean_if.resize(n_pos);
  out.lower95.resize(n_pos);
  out.upper95.resize(n_pos);
  out.mean_lower95.resize(n_pos);
  out.mean_upper95.resize(n_pos);
  // Noise draws in a fixed order (position-major) so the output is reproducible for a seed.
  Eigen::ArrayXXd noisy = model_if;
  for (Eigen::Index b = 0; b < noisy.cols(); ++b) {
    for (Eigen::Index m = 0; m < n_pos; ++m) noisy(m, b) += sigma_if[b / T] * std_normal(engine);
  }
  std::vector<double> values(static_cast<std::size_t>(noisy.cols()));
  std::vector<double> means(static_cast<std::size_t>(R));
  for (Eigen::Index m = 0; m < n_pos; ++m) {
    out.mean_if[m] = model_if.row(m).mean();
    for (Eigen::Index b = 0; b < noisy.cols(); ++b) values[static_cast<std::size_t>(b)] = noisy(m, b);
    out.lower95[m] = quantile_type7(values, 0.025);
    out.upper95[m] = quantile_type7(values, 0.975);
    for (int r = 0; r < R; ++r) means[static_cast<std::size_t>(r)] = model_if.row(m).segment(static_cast<Eigen::Index>(r) * T, T).mean();
    out.mean_lower95[m] = quantile_type7(means, 0.025);
    out.mean_upper95[m] = quantile_type7(means, 0.975);
  }
  return out;
}

void write_prediction_csv(std::ostream& out, const SsrPrediction& p) {
  out << "position_m,mean_if,lower95,upper95,mean_lower95,mean_upper95\n";
  out.precision(10);
  for (std::size_t m = 0; m < p.position_m.size(); ++m) {
    const auto i = static_cast<Eigen::Index>(m);
    out << p.position_m[m] << "," << p.mean_if[i] << "," << p.lower95[i] << "," << p.upper95[i] << ","
        << p.mean_lower95[i] << "," << p.mean_upper95[i] << "\n";
  }
}

}  // namespace ssrfleet::predict
