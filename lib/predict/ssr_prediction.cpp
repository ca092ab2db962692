#include "predict/ssr_prediction.hpp"

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>

#include "fleet/predictive_trucks.hpp"
#include "fleet/vehicle_classes.hpp"
#include "model/physical_effects.hpp"
#include "util/errors.hpp"
#include "util/quantile.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::predict {

void PredictionOptions::validate() const {
  if (theta_draws < 2) throw UsageError("predict: theta draws is " + std::to_string(theta_draws) + ", but must be >= 2");
  if (trucks_per_draw < 1) {
    throw UsageError("predict: trucks per draw is " + std::to_string(trucks_per_draw) + ", but must be >= 1");
  }
}

namespace {
// One class's predictive trucks simulated at the positions: the model IFs and the noisy ones
// (positions x R * T, θ-draw-major).
struct Simulated {
  Eigen::ArrayXXd model_if, noisy;
};

Simulated simulate(const fleet::PosteriorCloud& posterior, const site::Site& site,
                   const vehicle::PassIntegrator& integrator, Eigen::Index n_pos, const PredictionOptions& options) {
  // The fitted model's effects, rebuilt for this site from the posterior's spec; the force the
  // road feels keeps only some of them (model/physical_effects.hpp).
  const fleet::ModelSpec model = fleet::posterior_model(posterior, site);
  std::unique_ptr<fleet::PhysicalEffects> effects;
  if (model.extension) {
    effects = std::make_unique<fleet::PhysicalEffects>(*model.extension, posterior.site_fingerprint == site.fingerprint());
  }
  const int R = options.theta_draws, T = options.trucks_per_draw;
  util::throw_if_stopped();

  boost::random::mt19937_64 engine(options.seed);
  boost::random::normal_distribution<double> std_normal(0.0, 1.0);
  fleet::PredictiveTraffic traffic;
  traffic.bootstrap = options.traffic_bootstrap;
  // With the traffic bootstrap the band of the mean also carries the uncertainty of the observed
  // traffic mix; the stratified trucks keep simulation noise out of it (fleet/predictive_trucks.hpp:
  // independent draws would leave about s/√T, s the truck-to-truck spread of the IF, 0.01 on AS3 at
  // T = 100, reported as posterior uncertainty).
  const fleet::PredictiveTrucks drawn =
      fleet::draw_predictive_trucks(posterior, site.lateral_min_m(), site.lateral_max_m(), R, T, traffic, engine,
                                   effects.get());
  const site::TruckBatch& batch = drawn.trucks;
  const Eigen::ArrayXd& sigma_if = drawn.sigma_if;
  Simulated out;
  out.model_if.resize(n_pos, batch.size());
  fleet::simulate_predictive_trucks(site, &integrator, posterior, drawn, effects.get(), out.model_if);
  // Noise draws in a fixed order (position-major) so the output is reproducible for a seed.
  out.noisy = out.model_if;
  for (Eigen::Index b = 0; b < out.noisy.cols(); ++b) {
    for (Eigen::Index m = 0; m < n_pos; ++m) out.noisy(m, b) += sigma_if[b / T] * std_normal(engine);
  }
  return out;
}

SsrPrediction empty_prediction(const std::vector<double>& positions_m) {
  const auto n_pos = static_cast<Eigen::Index>(positions_m.size());
  SsrPrediction out;
  out.position_m = positions_m;
  out.mean_if.resize(n_pos);
  out.lower95.resize(n_pos);
  out.upper95.resize(n_pos);
  out.mean_lower95.resize(n_pos);
  out.mean_upper95.resize(n_pos);
  return out;
}
}  // namespace

SsrPrediction predict_ssr(const fleet::PosteriorCloud& posterior, const site::Site& site,
                          std::vector<double> positions_m, const PredictionOptions& options) {
  options.validate();
  if (positions_m.empty()) positions_m = site.sensor_positions_m();
  const vehicle::PassIntegrator integrator(site.surface().dx_m, site.surface().samples(), positions_m);
  const auto n_pos = static_cast<Eigen::Index>(positions_m.size());
  const int R = options.theta_draws, T = options.trucks_per_draw;
  const Simulated sim = simulate(posterior, site, integrator, n_pos, options);
  const Eigen::ArrayXXd& model_if = sim.model_if;
  const Eigen::ArrayXXd& noisy = sim.noisy;

  SsrPrediction out = empty_prediction(positions_m);
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

SsrPrediction predict_ssr_mixture(const fleet::ClassPosteriors& classes, const std::vector<double>& shares,
                                  const site::Site& site, std::vector<double> positions_m,
                                  const PredictionOptions& options) {
  options.validate();
  if (classes.empty() || shares.size() != classes.size()) {
    throw std::invalid_argument("predict_ssr_mixture: want one share per class");
  }
  std::vector<std::size_t> used;  // the classes with a share
  for (std::size_t c = 0; c < classes.size(); ++c) {
    if (shares[c] > 0.0) used.push_back(c);
  }
  if (used.empty()) throw UsageError("predict: every class has share 0");
  const auto class_options = [&](std::size_t c) {
    PredictionOptions o = options;
    o.seed = fleet::class_seed(options.seed, classes[c].label);
    return o;
  };
  // One class alone is that class's prediction (with its own seed: the unlabelled fit's is the seed).
  if (used.size() == 1) return predict_ssr(classes[used[0]].cloud, site, std::move(positions_m), class_options(used[0]));

  if (positions_m.empty()) positions_m = site.sensor_positions_m();
  const vehicle::PassIntegrator integrator(site.surface().dx_m, site.surface().samples(), positions_m);
  const auto n_pos = static_cast<Eigen::Index>(positions_m.size());
  const int R = options.theta_draws, T = options.trucks_per_draw;
  double total_share = 0.0;
  for (const std::size_t c : used) total_share += shares[c];
  std::vector<Simulated> sims;
  std::vector<double> w;  // the used classes' shares, normalised
  for (const std::size_t c : used) {
    sims.push_back(simulate(classes[c].cloud, site, integrator, n_pos, class_options(c)));
    w.push_back(shares[c] / total_share);
  }
  SsrPrediction out = empty_prediction(positions_m);
  std::vector<std::pair<double, double>> pooled;
  std::vector<double> means(static_cast<std::size_t>(R));
  const double columns = static_cast<double>(R) * T;
  for (Eigen::Index m = 0; m < n_pos; ++m) {
    // The mixture's mean is the share-weighted mean; its prediction limits are the quantiles of
    // the mixture of the classes' predictive draws (each draw of class c weighing w_c / (R T)).
    double mean = 0.0;
    pooled.clear();
    for (std::size_t k = 0; k < sims.size(); ++k) {
      mean += w[k] * sims[k].model_if.row(m).mean();
      for (Eigen::Index b = 0; b < sims[k].noisy.cols(); ++b) pooled.emplace_back(sims[k].noisy(m, b), w[k] / columns);
    }
    out.mean_if[m] = mean;
    out.lower95[m] = weighted_quantile(pooled, 0.025);
    out.upper95[m] = weighted_quantile(pooled, 0.975);
    // The classes' posteriors are independent, so θ draw r of every class together is one draw of
    // the mixture's parameters; its fleet mean is the share-weighted mean of the classes' means.
    for (int r = 0; r < R; ++r) {
      double mr = 0.0;
      for (std::size_t k = 0; k < sims.size(); ++k) {
        mr += w[k] * sims[k].model_if.row(m).segment(static_cast<Eigen::Index>(r) * T, T).mean();
      }
      means[static_cast<std::size_t>(r)] = mr;
    }
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
