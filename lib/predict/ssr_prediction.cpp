#include "predict/ssr_prediction.hpp"

#include <cmath>
#include <limits>
#include <string>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_01.hpp>
#include <boost/random/uniform_int_distribution.hpp>

#include "fleet/fleet_model.hpp"
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

template <class Engine>
double positive_normal(Engine& e, double mean, double sd) {
  boost::random::normal_distribution<double> n(mean, sd);
  for (;;) {
    const double x = n(e);
    if (x > 0.0) return x;
  }
}
}  // namespace

SsrPrediction predict_ssr(const fleet::PosteriorCloud& posterior, const site::Site& site,
                          std::vector<double> positions_m, const PredictionOptions& options) {
  options.validate();
  if (posterior.theta.rows() != fleet::kHyperCount || posterior.theta.cols() < 1 ||
      posterior.weights.size() != posterior.theta.cols() || posterior.speed_mps.empty()) {
    throw UsageError("predict: the posterior holds no usable draws");
  }
  if (positions_m.empty()) positions_m = site.sensor_positions_m();
  const vehicle::PassIntegrator integrator(site.surface().dx_m, site.surface().samples(), positions_m);
  const auto n_pos = static_cast<Eigen::Index>(positions_m.size());
  const int R = options.theta_draws, T = options.trucks_per_draw;

  boost::random::mt19937_64 engine(options.seed);
  boost::random::uniform_01<double> unif;
  boost::random::normal_distribution<double> std_normal(0.0, 1.0);
  const auto thetas = draw_by_weight(posterior.weights, R, unif(engine));
  boost::random::uniform_int_distribution<std::size_t> pick_truck(0, posterior.speed_mps.size() - 1);
  const double zlo = site.lateral_min_m(), zhi = site.lateral_max_m();

  site::TruckBatch batch;
  batch.resize(static_cast<Eigen::Index>(R) * T);
  Eigen::ArrayXd sigma_if(R);
  for (int r = 0; r < R; ++r) {
    const Eigen::Index p = thetas[static_cast<std::size_t>(r)];
    const auto th = [&](int j) { return posterior.theta(j, p); };
    sigma_if[r] = th(fleet::kSigmaIf);
    if (fleet::log_normal_mass(zlo, zhi, th(fleet::kZ), th(fleet::kSigmaZ)) < std::log(1e-6)) {
      throw UsageError("predict: the fleet's lateral distribution N(" + std::to_string(th(fleet::kZ)) + ", " +
                       std::to_string(th(fleet::kSigmaZ)) + "^2) misses this road's surface [" + std::to_string(zlo) +
                       ", " + std::to_string(zhi) + "] m");
    }
    for (int t = 0; t < T; ++t) {
      const Eigen::Index b = static_cast<Eigen::Index>(r) * T + t;
      const std::size_t obs = pick_truck(engine);
      batch.speed_mps[b] = posterior.speed_mps[obs];
      batch.sprung_mass_kg[b] = posterior.sprung_mass_kg[obs];
      batch.stiffness_npm[b] = positive_normal(engine, th(fleet::kK), th(fleet::kSigmaK));
      batch.tyre_stiffness_npm[b] = positive_normal(engine, th(fleet::kKt), th(fleet::kSigmaKt));
      double z;
      do z = th(fleet::kZ) + th(fleet::kSigmaZ) * std_normal(engine);
      while (z < zlo || z > zhi);
      batch.lateral_m[b] = z;
    }
  }
  Eigen::ArrayXXd model_if(n_pos, batch.size());
  site.impact_factors_at(integrator, batch, model_if);

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
