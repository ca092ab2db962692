#include "weigh/predicted_impact_factors.hpp"

#include <boost/random/mersenne_twister.hpp>

#include "fleet/predictive_trucks.hpp"
#include "util/errors.hpp"

namespace ssrfleet::weigh {

PredictedImpactFactors predict_impact_factors(const fleet::PosteriorCloud& posterior, const site::Site& site,
                                              double speed_mps, double sprung_mass_kg, const PredictionSize& size) {
  if (size.theta_draws < 2 || size.trucks_per_draw < 2) {
    throw UsageError("weigh: need at least 2 theta draws and 2 trucks per draw (a covariance within draws)");
  }
  const int R = size.theta_draws, T = size.trucks_per_draw;
  // A fresh engine from the same seed on every call: the θ draws and the (k, k_t, z) uniforms
  // are then identical whatever the trial mass, so μ(m2) is a smooth, deterministic function of
  // m2 and the fixed-point iteration of static_weight.cpp sees no Monte Carlo jitter between
  // its steps (common random numbers).
  boost::random::mt19937_64 engine(size.seed);
  fleet::PredictiveTraffic traffic;
  traffic.speed_mps = speed_mps;
  traffic.sprung_mass_kg = sprung_mass_kg;
  // A fitted model whole: the forces weighed went through the sensors (a gain included) at the
  // logged speeds (a speed bias included), on the site it was fitted on.
  const fleet::ModelSpec model = fleet::posterior_model(posterior, site);
  const fleet::PredictiveTrucks drawn = fleet::draw_predictive_trucks(
      posterior, site.lateral_min_m(), site.lateral_max_m(), R, T, traffic, engine, model.extension.get());
  Eigen::ArrayXXd model_if(site.sensors(), drawn.trucks.size());
  fleet::simulate_predictive_trucks(site, nullptr, posterior, drawn, model.extension.get(), model_if);

  const Eigen::Index M = model_if.rows();
  PredictedImpactFactors out;
  out.theta_means.resize(M, R);
  Eigen::MatrixXd within = Eigen::MatrixXd::Zero(M, M);
  for (int r = 0; r < R; ++r) {
    const Eigen::MatrixXd block = model_if.middleCols(static_cast<Eigen::Index>(r) * T, T).matrix();
    out.theta_means.col(r) = block.rowwise().mean();
    const Eigen::MatrixXd centred = block.colwise() - out.theta_means.col(r);
    within += centred * centred.transpose();
  }
  out.mean = out.theta_means.rowwise().mean();
  out.covariance = within / (static_cast<double>(R) * (T - 1));
  out.covariance.diagonal().array() += drawn.sigma_if.square().mean();
  return out;
}

}  // namespace ssrfleet::weigh
