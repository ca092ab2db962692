#include "fleet/smc_runs.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "fleet/equal_weight_draws.hpp"
#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"
#include "smc/rng.hpp"
#include "util/convergence.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_runs(const std::vector<PosteriorCloud>& runs) {
  if (runs.empty()) throw std::invalid_argument("pool_runs: no runs");
  const PosteriorCloud& first = runs.front();
  for (std::size_t r = 1; r < runs.size(); ++r) {
    const PosteriorCloud& c = runs[r];
    auto differs = [&](const std::string& what) {
      throw std::invalid_argument("pool_runs: run " + std::to_string(r + 1) + " differs from run 1 in its " + what);
    };
    if (c.method != first.method) differs("method");
    if (c.site_fingerprint != first.site_fingerprint) differs("site");
    if (c.trucks_seen != first.trucks_seen || c.speed_mps != first.speed_mps) differs("trucks");
    if (c.model != first.model || c.psi_names != first.psi_names) differs("model");
    if (c.theta.rows() != first.theta.rows() || c.theta.cols() != first.theta.cols() ||
        c.psi.rows() != first.psi.rows() || c.psi.cols() != first.psi.cols() || c.weights.size() != c.theta.cols()) {
      differs("number of particles");
    }
    if (c.pooled_sweeps != first.pooled_sweeps) differs("pooled final sweeps");
    if (c.chains != 1) differs("chains (a run is one chain)");
  }
  if (first.chains != 1) throw std::invalid_argument("pool_runs: run 1 already pools several chains");
}

double sd_over_runs(const std::vector<double>& x) {
  const double n = static_cast<double>(x.size());
  double mean = 0.0, ss = 0.0;
  for (double v : x) mean += v / n;
  for (double v : x) ss += (v - mean) * (v - mean);
  return std::sqrt(ss / (n - 1.0));
}

// One parameter's row `row` of each run's draws (theta or psi, chosen by `draws_of`).
template <class DrawsOf>
ParameterConvergence convergence_of(const std::string& name, const std::vector<PosteriorCloud>& runs, Eigen::Index row,
                                    DrawsOf draws_of) {
  const auto R = static_cast<Eigen::Index>(runs.size());
  const Eigen::Index P = runs.front().theta.cols();
  Eigen::MatrixXd equal(P, R);
  std::vector<double> means, q05, q95;
  double pooled_mean = 0.0;
  for (Eigen::Index r = 0; r < R; ++r) {
    const PosteriorCloud& c = runs[static_cast<std::size_t>(r)];
    const Eigen::VectorXd x = draws_of(c).row(row).transpose();
    const Eigen::VectorXd w = (c.weights / c.weights.sum()).matrix();
    means.push_back(w.dot(x));
    q05.push_back(weighted_quantile(x, w, 0.05));
    q95.push_back(weighted_quantile(x, w, 0.95));
    pooled_mean += means.back() / static_cast<double>(R);
    const std::vector<Eigen::Index> picked = systematic_half_offset(c.weights, P);
    for (Eigen::Index d = 0; d < P; ++d) equal(d, r) = x[picked[static_cast<std::size_t>(d)]];
  }
  double pooled_var = 0.0;
  for (Eigen::Index r = 0; r < R; ++r) {
    const PosteriorCloud& c = runs[static_cast<std::size_t>(r)];
    const Eigen::ArrayXd x = draws_of(c).row(row).transpose().array();
    pooled_var += ((x - pooled_mean).square() * c.weights).sum() / c.weights.sum() / static_cast<double>(R);
  }
  ParameterConvergence p;
  p.name = name;
  p.rhat = util::rhat_unsplit(equal);
  p.ess_bulk = kNaN;
  p.ess_tail = kNaN;
  const double root_r = std::sqrt(static_cast<double>(R));
  p.mcse_mean = sd_over_runs(means) / root_r;
  p.mcse_q05 = sd_over_runs(q05) / root_r;
  p.mcse_q95 = sd_over_runs(q95) / root_r;
  // A parameter pinned at one value (a box edge, a fixed ψ) has no error to measure.
  p.ess_equivalent = p.mcse_mean > 0.0 ? pooled_var / (p.mcse_mean * p.mcse_mean) : kNaN;
  return p;
}
}  // namespace

std::uint64_t run_seed(std::uint64_t seed, int run) {
  if (run == 0) return seed;
  return smc::RngFactory(seed).child(0x72756eULL /* "run" */, static_cast<std::uint64_t>(run)).key();
}

std::vector<ParameterConvergence> run_convergence(const std::vector<PosteriorCloud>& runs) {
  check_runs(runs);
  if (runs.size() < 2) throw std::invalid_argument("run_convergence: needs at least 2 runs");
  std::vector<ParameterConvergence> out;
  const auto theta = [](const PosteriorCloud& c) -> const Eigen::MatrixXd& { return c.theta; };
  const auto psi = [](const PosteriorCloud& c) -> const Eigen::MatrixXd& { return c.psi; };
  for (int j = 0; j < kHyperCount; ++j)
    out.push_back(convergence_of(std::string(kHyperNames[static_cast<std::size_t>(j)]), runs, j, theta));
  const PosteriorCloud& first = runs.front();
  for (Eigen::Index j = 0; j < first.psi.rows(); ++j)
    out.push_back(convergence_of(first.psi_names[static_cast<std::size_t>(j)], runs, j, psi));
  return out;
}

PosteriorCloud pool_runs(const std::vector<PosteriorCloud>& runs) {
  check_runs(runs);
  if (runs.size() == 1) return runs.front();
  const auto R = static_cast<Eigen::Index>(runs.size());
  const Eigen::Index P = runs.front().theta.cols();
  PosteriorCloud pooled = runs.front();
  pooled.theta.resize(runs.front().theta.rows(), P * R);
  pooled.psi.resize(runs.front().psi.rows(), P * R);
  pooled.weights.resize(P * R);
  double inverse_ess = 0.0, evidence_max = -std::numeric_limits<double>::infinity();
  for (const auto& c : runs) evidence_max = std::max(evidence_max, c.log_evidence);
  double evidence_sum = 0.0;
  for (Eigen::Index r = 0; r < R; ++r) {
    const PosteriorCloud& c = runs[static_cast<std::size_t>(r)];
    pooled.theta.middleCols(r * P, P) = c.theta;
    if (c.psi.rows() > 0) pooled.psi.middleCols(r * P, P) = c.psi;
    pooled.weights.segment(r * P, P) = c.weights / c.weights.sum() / static_cast<double>(R);
    inverse_ess += 1.0 / c.weight_ess;
    evidence_sum += std::exp(c.log_evidence - evidence_max);
  }
  pooled.chains = static_cast<int>(R);
  pooled.convergence = run_convergence(runs);
  pooled.weight_ess = static_cast<double>(R * R) / inverse_ess;
  pooled.log_evidence = std::isfinite(evidence_max)
                            ? evidence_max + std::log(evidence_sum / static_cast<double>(R))
                            : runs.front().log_evidence;
  return pooled;
}

}  // namespace ssrfleet::fleet
