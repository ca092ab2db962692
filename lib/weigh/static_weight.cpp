#include "weigh/static_weight.hpp"

#include <cmath>
#include <string>

#include <Eigen/Cholesky>

#include "util/errors.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::weigh {

void WeighOptions::validate() const {
  if (prediction.theta_draws < 2) throw UsageError("--draws must be >= 2");
  if (prediction.trucks_per_draw < 2) throw UsageError("--trucks-per-draw must be >= 2 (a covariance within draws)");
  if (!(relative_tolerance > 0.0 && relative_tolerance < 0.1)) throw UsageError("--tolerance must be in (0, 0.1)");
  if (max_iterations < 1) throw UsageError("--max-iterations must be >= 1");
}

CombinedSensors combine_sensors(const Eigen::VectorXd& force_n, const Eigen::VectorXd& mean_if,
                                const Eigen::MatrixXd& if_covariance) {
  const Eigen::Index M = force_n.size();
  if (mean_if.size() != M || if_covariance.rows() != M || if_covariance.cols() != M || M < 1) {
    throw std::invalid_argument("combine_sensors: forces, mean IFs and covariance disagree in size");
  }
  if (!((mean_if.array() > 0.0).all())) throw NumericalError("weigh: a predicted mean impact factor is not positive");
  // C~ = D⁻¹ C D⁻¹: the covariance of the corrected readings' relative errors IF_m / μ_m - 1.
  const Eigen::VectorXd inv_mu = mean_if.cwiseInverse();
  const Eigen::MatrixXd relative = inv_mu.asDiagonal() * if_covariance * inv_mu.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd> llt(relative);
  if (llt.info() != Eigen::Success) throw NumericalError("weigh: the predicted impact-factor covariance is not positive definite");
  const Eigen::VectorXd c_inv_one = llt.solve(Eigen::VectorXd::Ones(M));
  const double precision = c_inv_one.sum();  // 1ᵀ C~⁻¹ 1
  CombinedSensors out;
  out.weights = c_inv_one / precision;
  out.static_n = out.weights.dot(force_n.cwiseProduct(inv_mu));
  out.relative_variance = 1.0 / precision;
  return out;
}

records::StaticWeight estimate_static_weight(const fleet::PosteriorCloud& posterior, const site::Site& site,
                                             const records::ForceRecord& record, const std::string& source_name,
                                             const WeighOptions& options, FixedPointTrace* trace) {
  options.validate();
  const double g = vehicle::gravity_mps2, m1 = site.options().unsprung_mass_kg;
  const double plain = record.force_n.mean();
  const auto sprung_mass_of = [&](double static_n) {
    const double m2 = static_n / g - m1;
    if (m2 < options.min_sprung_mass_kg) {
      throw DataError(source_name, record.line, "force_1",
                      "the forces imply a sprung mass of " + std::to_string(m2) + " kg (static wheel load " +
                          std::to_string(static_n / 1e3) + " kN, unsprung mass " + std::to_string(m1) +
                          " kg), below " + std::to_string(options.min_sprung_mass_kg) + " kg: not a truck");
    }
    return m2;
  };
  if (trace) trace->estimates_n = {plain};

  double estimate = plain;
  PredictedImpactFactors predicted;
  CombinedSensors combined;
  int iterations = 0;
  for (bool converged = false; !converged;) {
    if (iterations == options.max_iterations) {
      throw NumericalError("weigh: truck '" + record.truck_id + "' (" + source_name + ":" + std::to_string(record.line) +
                           "): the fixed point did not converge in " + std::to_string(iterations) + " iterations");
    }
    predicted = predict_impact_factors(posterior, site, record.speed_mps, sprung_mass_of(estimate), options.prediction);
    combined = combine_sensors(record.force_n, predicted.mean, predicted.covariance);
    ++iterations;
    converged = std::abs(combined.static_n - estimate) <= options.relative_tolerance * combined.static_n;
    estimate = combined.static_n;
    if (trace) trace->estimates_n.push_back(estimate);
  }

  // The posterior's share: the same weights on each θ draw's own mean pattern.
  const Eigen::Index R = predicted.theta_means.cols();
  Eigen::ArrayXd per_theta(R);
  for (Eigen::Index r = 0; r < R; ++r) {
    per_theta[r] = combined.weights.dot(record.force_n.cwiseQuotient(predicted.theta_means.col(r)));
  }
  const double posterior_var = (per_theta - per_theta.mean()).square().sum() / static_cast<double>(R - 1);
  const double estimator_var = estimate * estimate * combined.relative_variance;
  const double sd = std::sqrt(posterior_var + estimator_var);

  records::StaticWeight out;
  out.truck_id = record.truck_id;
  out.static_kn = estimate / 1e3;
  out.static_kn_q025 = (estimate - 1.959963984540054 * sd) / 1e3;
  out.static_kn_q975 = (estimate + 1.959963984540054 * sd) / 1e3;
  out.plain_mean_kn = plain / 1e3;
  out.iterations = iterations;
  return out;
}

}  // namespace ssrfleet::weigh
