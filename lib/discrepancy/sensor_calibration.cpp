#include "discrepancy/sensor_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fleet/joint_sites.hpp"
#include "smc/parallel.hpp"
#include "smc/resampling.hpp"
#include "util/errors.hpp"

namespace ssrfleet::discrepancy {

namespace {

// One θ draw's complete-data estimate at one site: per sensor Σ y μ, Σ μ², and σ_IF.
struct DrawSums {
  Eigen::VectorXd y_mu, mu_mu;
  double sigma_if = 0.0;
};

std::vector<SensorGains> estimate_gains(const fleet::MarginalSmc& fit, const MarginalDrawOptions& o) {
  if (o.draws < 2) throw UsageError("sensor calibration: draws must be at least 2 (the standard error needs two)");
  if (o.mh_steps < 0) throw UsageError("sensor calibration: mh_steps must be >= 0");
  if (o.threads < 1) throw UsageError("sensor calibration: threads must be at least 1");
  const fleet::MarginalTarget& target = fit.target();
  const auto& sites = target.sites();
  // Each site's trucks, in truck order.
  std::vector<std::vector<std::size_t>> trucks_of(sites.size());
  for (std::size_t t = 0; t < static_cast<std::size_t>(target.trucks()); ++t) trucks_of[target.absorbed().site(t)].push_back(t);

  const smc::RngFactory root = smc::RngFactory(o.seed).child(0x63616c6962ULL /* "calib" */);
  smc::Rng pick = root.child(0).stream(0);
  const auto chosen = smc::systematic_resampling(fit.sampler().weights(), o.draws, pick);
  const auto D = static_cast<Eigen::Index>(chosen.size());
  // sums[d][s]: draw d at site s. Each (draw, site, truck) has its own stream, so the result does not
  // depend on the thread count.
  std::vector<std::vector<DrawSums>> sums(chosen.size(), std::vector<DrawSums>(sites.size()));
  const smc::ParallelFor parallel(o.threads);
  parallel(D, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index d = begin; d < end; ++d) {
      const Eigen::Index p = chosen[static_cast<std::size_t>(d)];
      fleet::HyperVector theta;
      for (int j = 0; j < fleet::kHyperCount; ++j) theta[static_cast<std::size_t>(j)] = target.theta()(j, p);
      for (std::size_t s = 0; s < sites.size(); ++s) {
        DrawSums& out = sums[static_cast<std::size_t>(d)][s];
        out.sigma_if = theta[fleet::kSigmaIf];
        const int M = sites[s]->sensors();
        out.y_mu = Eigen::VectorXd::Zero(M);
        out.mu_mu = Eigen::VectorXd::Zero(M);
        if (trucks_of[s].empty()) continue;
        const TruckLatentDraws drawn = draw_truck_latents(
            *sites[s], target, theta, root.child(1 + s, static_cast<std::uint64_t>(d)), o.mh_steps, trucks_of[s]);
        for (std::size_t i = 0; i < trucks_of[s].size(); ++i) {
          const auto y = target.absorbed().impact_factors(trucks_of[s][i]);
          const auto mu = drawn.model_if.col(static_cast<Eigen::Index>(i));
          out.y_mu.array() += y.array() * mu.array();
          out.mu_mu.array() += mu.array().square();
        }
      }
    }
  });

  std::vector<SensorGains> gains(sites.size());
  for (std::size_t s = 0; s < sites.size(); ++s) {
    const int M = sites[s]->sensors();
    SensorGains& g = gains[s];
    g.trucks = static_cast<long>(trucks_of[s].size());
    if (trucks_of[s].empty()) {
      g.gain = Eigen::VectorXd::Ones(M);
      g.se = Eigen::VectorXd::Constant(M, std::numeric_limits<double>::infinity());
      continue;
    }
    // Per draw: ĝ_d = Σ y μ / Σ μ², complete-data variance σ_d² / Σ μ². The pooled estimate weights
    // each draw by 1/σ_d² (the M-step of the expected complete-data log-likelihood); the standard
    // error is Rubin's T = W + (1 + 1/D) B over the per-draw estimates.
    Eigen::VectorXd num = Eigen::VectorXd::Zero(M), den = Eigen::VectorXd::Zero(M), within = Eigen::VectorXd::Zero(M);
    Eigen::MatrixXd per_draw(M, D);
    for (Eigen::Index d = 0; d < D; ++d) {
      const DrawSums& ds = sums[static_cast<std::size_t>(d)][s];
      const double w = 1.0 / (ds.sigma_if * ds.sigma_if);
      num += w * ds.y_mu;
      den += w * ds.mu_mu;
      per_draw.col(d) = ds.y_mu.cwiseQuotient(ds.mu_mu);
      within.array() += ds.sigma_if * ds.sigma_if / ds.mu_mu.array();
    }
    g.gain = num.cwiseQuotient(den);
    within /= static_cast<double>(D);
    const Eigen::VectorXd mean = per_draw.rowwise().mean();
    const Eigen::VectorXd between = (per_draw.colwise() - mean).array().square().rowwise().sum() / static_cast<double>(D - 1);
    g.se = (within + (1.0 + 1.0 / static_cast<double>(D)) * between).cwiseSqrt();
  }
  return gains;
}

}  // namespace

std::vector<SensorGains> estimate_sensor_gains(const fleet::OnlineFit& fit, const MarginalDrawOptions& options) {
  return fleet::visit_core(
      fit,
      [](const fleet::FleetSmc&) -> std::vector<SensorGains> {
        throw UsageError("sensor calibration: the fit must run on the marginal core");
      },
      [&](const fleet::MarginalSmc& marginal) { return estimate_gains(marginal, options); });
}

CalibratedFit fit_with_sensor_calibration(const std::vector<records::WimRecord>& records,
                                          std::vector<Eigen::VectorXd> initial, const FitRecords& fit_records,
                                          const CalibrationOptions& o,
                                          const std::function<void(int, const CalibrationRound&)>& after_round) {
  if (o.max_rounds < 1) throw UsageError("sensor calibration: max_rounds must be at least 1");
  if (!(o.tolerance_se > 0.0)) throw UsageError("sensor calibration: the tolerance must be positive");
  for (const auto& r : records) {
    if (r.site >= initial.size() || initial[r.site].size() != r.impact_factor.size()) {
      throw UsageError("sensor calibration: truck " + r.truck_id + "'s site has no gains of its sensor count");
    }
  }
  CalibratedFit out;
  out.gains = std::move(initial);
  for (int round = 1; round <= o.max_rounds; ++round) {
    std::vector<records::WimRecord> corrected = records;
    for (auto& r : corrected) fleet::remove_sensor_gains(r, out.gains[r.site]);
    out.fit = fit_records(corrected);
    if (out.fit == nullptr) throw UsageError("sensor calibration: the fit must run on the marginal core");
    CalibrationRound r;
    r.step = estimate_sensor_gains(*out.fit, o.draws);  // UsageError if the fit is on another core
    out.se.assign(r.step.size(), Eigen::VectorXd());
    for (std::size_t s = 0; s < r.step.size(); ++s) {
      const SensorGains& g = r.step[s];
      // The standard error of the whole gain: the step's, scaled to the gain it multiplies.
      out.se[s] = g.se.cwiseProduct(out.gains[s]);
      for (Eigen::Index j = 0; j < g.gain.size(); ++j) {
        if (std::isfinite(g.se[j])) r.largest_step_se = std::max(r.largest_step_se, std::abs(g.gain[j] - 1.0) / g.se[j]);
      }
    }
    out.rounds.push_back(r);
    if (after_round) after_round(round, out.rounds.back());
    if (r.largest_step_se < o.tolerance_se) {
      out.converged = true;
      break;
    }
    if (round == o.max_rounds) break;  // the fit stays the one these gains were divided out of
    for (std::size_t s = 0; s < r.step.size(); ++s) out.gains[s] = out.gains[s].cwiseProduct(r.step[s].gain);
  }
  return out;
}

}  // namespace ssrfleet::discrepancy
