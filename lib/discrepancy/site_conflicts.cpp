#include "discrepancy/site_conflicts.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>

#include "fleet/joint_sites.hpp"
#include "fleet/replay.hpp"
#include "model/fleet_model.hpp"
#include "util/errors.hpp"

namespace ssrfleet::discrepancy {

namespace {

// The four stiffness hyperparameters the check compares, and whether each is on the log scale.
constexpr int kTested[4] = {fleet::kK, fleet::kSigmaK, fleet::kKt, fleet::kSigmaKt};
constexpr bool kTestedLog[4] = {false, true, false, true};

struct Moments {
  std::array<double, 7> mean{}, sd{};
  Eigen::Vector4d phi_mean;
  Eigen::Matrix4d phi_cov;
};

Moments moments_of(const fleet::PosteriorCloud& c) {
  Moments m;
  const Eigen::ArrayXd& w = c.weights;
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const Eigen::ArrayXd x = c.theta.row(h).transpose().array();
    const double mean = (w * x).sum();
    m.mean[static_cast<std::size_t>(h)] = mean;
    m.sd[static_cast<std::size_t>(h)] = std::sqrt((w * (x - mean).square()).sum());
  }
  Eigen::MatrixXd phi(4, c.theta.cols());
  for (int j = 0; j < 4; ++j) {
    const Eigen::ArrayXd x = c.theta.row(kTested[j]).transpose().array();
    phi.row(j) = (kTestedLog[j] ? x.log() : x).matrix().transpose();
  }
  m.phi_mean = phi * w.matrix();
  const Eigen::MatrixXd centred = phi.colwise() - m.phi_mean;
  m.phi_cov = centred * w.matrix().asDiagonal() * centred.transpose();
  return m;
}

fleet::PosteriorCloud fit_sites(const std::vector<const site::Site*>& sites,
                                std::vector<std::vector<records::WimRecord>> logs, const SiteConflictOptions& options,
                                std::uint64_t seed) {
  fleet::OnlineFitOptions o = options.fit;
  o.core = fleet::choose_core(o.extension, fleet::Core::kMarginal);  // several sites fit on the marginal core
  o.sampler().seed = seed;
  auto fit = fleet::make_online_fit(sites, o);
  fleet::replay(*fit, fleet::merge_site_records(std::move(logs)), {});
  return fit->cloud();
}

}  // namespace

double chi2_4_tail(double x) { return x <= 0.0 ? 1.0 : std::exp(-0.5 * x) * (1.0 + 0.5 * x); }

std::vector<SiteConflict> check_site_conflicts(const std::vector<const site::Site*>& sites,
                                               const std::vector<std::vector<records::WimRecord>>& per_site,
                                               const SiteConflictOptions& options) {
  const std::size_t S = sites.size();
  if (S < 2 || per_site.size() != S) throw UsageError("the site check compares each site with the others: needs two sites or more");
  for (std::size_t s = 0; s < S; ++s) {
    if (per_site[s].empty()) throw UsageError("the site check needs records at every site; site " + std::to_string(s) + " has none");
  }
  if (!(options.alpha > 0.0 && options.alpha < 1.0)) throw UsageError("the site check's alpha must be in (0, 1)");
  const std::uint64_t seed = options.fit.marginal.sampler.seed;
  std::vector<SiteConflict> out(S);
  std::vector<std::size_t> in;  // the sites still checked
  for (std::size_t s = 0; s < S; ++s) in.push_back(s);
  std::uint64_t fits = 0;  // each fit's seed: the run's seed + its number
  for (int round = 1;; ++round) {
    for (const std::size_t s : in) {
      SiteConflict& c = out[s];
      c.site = s;
      c.round = round;
      c.trucks = static_cast<long>(per_site[s].size());
      c.compared_with = in.size() - 1;
      const std::string where = "round " + std::to_string(round) + ", site " + std::to_string(s + 1) + " of " +
                                std::to_string(S) + ": ";
      if (options.progress) options.progress(where + "alone");
      const Moments alone = moments_of(fit_sites({sites[s]}, {per_site[s]}, options, seed + fits++));
      std::vector<const site::Site*> rest_sites;
      std::vector<std::vector<records::WimRecord>> rest_logs;
      for (const std::size_t r : in) {
        if (r == s) continue;
        rest_sites.push_back(sites[r]);
        rest_logs.push_back(per_site[r]);
      }
      if (options.progress) options.progress(where + "the " + std::to_string(rest_sites.size()) + " other sites");
      const Moments rest = moments_of(fit_sites(rest_sites, std::move(rest_logs), options, seed + fits++));
      c.alone_mean = alone.mean;
      c.alone_sd = alone.sd;
      c.rest_mean = rest.mean;
      c.rest_sd = rest.sd;
      const Eigen::Vector4d delta = alone.phi_mean - rest.phi_mean;
      const Eigen::Matrix4d cov = alone.phi_cov + rest.phi_cov;
      const Eigen::LDLT<Eigen::Matrix4d> ldlt(cov);
      c.distance2 = ldlt.info() == Eigen::Success ? delta.dot(ldlt.solve(delta)) : std::numeric_limits<double>::infinity();
      c.p_value = chi2_4_tail(c.distance2);
    }
    // The worst site of the round, if flagged, is named and taken out; the rest are checked again.
    // Two sites cannot say which of them differs: a conflict between them marks both, flags neither.
    const double threshold = options.alpha / static_cast<double>(S);
    std::size_t worst = in.front();
    for (const std::size_t s : in)
      if (out[s].distance2 > out[worst].distance2) worst = s;
    if (!(out[worst].p_value < threshold)) break;
    if (in.size() == 2) {
      for (const std::size_t s : in) out[s].undecided = true;
      break;
    }
    out[worst].flagged = true;
    in.erase(std::find(in.begin(), in.end(), worst));
    if (in.size() < 2) break;
  }
  return out;
}

}  // namespace ssrfleet::discrepancy
