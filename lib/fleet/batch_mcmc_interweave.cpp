#include "fleet/batch_mcmc_interweave.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <boost/random/normal_distribution.hpp>

#include "model/truncated_samplers.hpp"
#include "util/check.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr int kBaseEvery = 50;      // steps between updates of base_sd_ from the chain's moments
constexpr int kBaseMinSteps = 200;  // moments needed before the first such update
}  // namespace

AncillaryUpdater::AncillaryUpdater(Hyper mean_index, Hyper sd_index, bool truncated, int trucks)
    : mean_index_(mean_index), sd_index_(sd_index), truncated_(truncated), trucks_(trucks) {
  check_greater_or_equal("AncillaryUpdater", "trucks", trucks, 1);
  base_sd_.setZero();
}

bool AncillaryUpdater::step(boost::random::mt19937_64& engine, HyperVector& theta,
                            Eigen::Ref<Eigen::ArrayXd> latent, Eigen::Ref<Eigen::ArrayXd> ssr,
                            double inv2var_if, const AncillarySsrFunction& ssr_of, const PriorBounds& prior,
                            const LateralRange& range, double target_acceptance, bool adapt, bool collect) {
  const auto mi = static_cast<std::size_t>(mean_index_), si = static_cast<std::size_t>(sd_index_);
  const double mean = theta[mi], sd = theta[si];
  const double n = static_cast<double>(trucks_);
  if (!base_set_) {
    // Before the chain has moments: the scale of the conditional of (M, log S) given the latents
    // (M: S / sqrt(N); log S: 1 / sqrt(2N)); the data given eps make it narrower, which the
    // Robbins-Monro scale takes up.
    base_sd_ = Eigen::Vector2d(sd / std::sqrt(n), 1.0 / std::sqrt(2.0 * n));
    base_set_ = true;
  }

  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const double step_scale = std::exp(log_scale_);
  const double mean_new = mean + step_scale * base_sd_[0] * normal(engine);
  const double log_sd_step = step_scale * base_sd_[1] * normal(engine);
  const double sd_new = sd * std::exp(log_sd_step);
  ++tried_;

  double accept_prob = 0.0;
  bool accepted = false;
  const bool in_box = mean_new >= prior.lo[mi] && mean_new <= prior.hi[mi] && sd_new >= prior.lo[si] &&
                      sd_new <= prior.hi[si];
  if (in_box) {
    eps_ = (latent - mean) / sd;
    proposal_ = mean_new + sd_new * eps_;
    // Support of the latent: k, kt > 0 (zero likelihood otherwise), z on the road.
    const bool in_support = truncated_ ? (proposal_ >= range.lo_m).all() && (proposal_ <= range.hi_m).all()
                                       : (proposal_ > 0.0).all();
    if (in_support) {
      ssr_of(proposal_, ssr_proposal_);
      // log p(theta' | eps, y) - log p(theta | eps, y) + log(S'/S) (the log-scale walk's Jacobian);
      // the uniform prior is constant inside the box.
      double log_alpha = -inv2var_if * (ssr_proposal_.sum() - ssr.sum()) + log_sd_step;
      if (truncated_) {
        log_alpha -= n * (log_normal_mass(range.lo_m, range.hi_m, mean_new, sd_new) -
                          log_normal_mass(range.lo_m, range.hi_m, mean, sd));
      }
      if (std::isnan(log_alpha)) log_alpha = -std::numeric_limits<double>::infinity();
      accept_prob = std::min(1.0, std::exp(log_alpha));
      if (std::log(uniform_open01(engine)) < log_alpha) {
        theta[mi] = mean_new;
        theta[si] = sd_new;
        latent = proposal_;
        ssr = ssr_proposal_;
        accepted = true;
        ++accepted_;
      }
    }
  }

  if (adapt) {
    ++adapt_steps_;
    const double gain = std::min(1.0, 3.0 * std::pow(static_cast<double>(adapt_steps_), -0.6));
    log_scale_ = std::clamp(log_scale_ + gain * (accept_prob - target_acceptance), -15.0, 5.0);
    if (collect) {
      const Eigen::Vector2d x(theta[mi], std::log(theta[si]));
      ++moment_count_;
      const Eigen::Vector2d delta = x - moment_mean_;
      moment_mean_ += delta / static_cast<double>(moment_count_);
      moment_m2_ += delta.cwiseProduct(x - moment_mean_);
      if (moment_count_ >= kBaseMinSteps && moment_count_ % kBaseEvery == 0) {
        const Eigen::Vector2d chain_sd = (moment_m2_ / static_cast<double>(moment_count_ - 1)).cwiseSqrt();
        // Optimal random-walk scaling for a 2-D Gaussian (Roberts, Gelman & Gilks 1997); the
        // conditional given eps is narrower than the marginal, log_scale_ takes that up.
        if ((chain_sd.array() > 0.0).all()) base_sd_ = 2.38 / std::sqrt(2.0) * chain_sd;
      }
    }
  }
  return accepted;
}

}  // namespace ssrfleet::fleet
