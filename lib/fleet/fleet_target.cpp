#include "fleet/fleet_target.hpp"
#include "fleet/fleet_target_draws.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <string>

#include "model/extended_forward.hpp"
#include "model/extension_conditionals.hpp"
#include "model/fleet_conditionals.hpp"
#include "model/truncated_samplers.hpp"
#include "smc/mh_kernel.hpp"
#include "smc/rng.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

using detail::standard_normal;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

FleetTarget::FleetTarget(const site::Site& site, Options options)
    : site_(site), options_(options), lateral_{site.lateral_min_m(), site.lateral_max_m()},
      sensors_(site.sensors()), log_prior_inside_(options.prior.log_prior(options.prior.lo)) {
  if (options_.particles < 2) {
    throw UsageError("fleet target: particles is " + std::to_string(options_.particles) + ", but must be at least 2");
  }
  if (!(options_.defensive_share > 0.0 && options_.defensive_share < 1.0)) {
    throw UsageError("fleet target: the defensive share of a new truck's proposal must be in (0, 1)");
  }
  if (options_.proposal_draws < 1) throw UsageError("fleet target: proposal draws must be at least 1");
  theta_.resize(kHyperCount, options_.particles);
  psi_.resize(options_.extension != nullptr ? options_.extension->dim() : 0, options_.particles);
  sums_ = Eigen::MatrixXd::Zero(kSumCount, options_.particles);
}

HyperVector FleetTarget::theta_of(Eigen::Index particle) const {
  HyperVector t;
  for (int j = 0; j < kHyperCount; ++j) t[j] = theta_(j, particle);
  return t;
}

void FleetTarget::initialise(const smc::RngFactory& rngs) {
  const auto& prior = options_.prior;
  for (Eigen::Index i = 0; i < options_.particles; ++i) {
    smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
    for (int j = 0; j < kHyperCount; ++j) theta_(j, i) = prior.lo[j] + (prior.hi[j] - prior.lo[j]) * smc::uniform01(rng);
    if (options_.extension != nullptr) {
      const auto& ps = options_.extension->parameters();
      for (Eigen::Index j = 0; j < psi_.rows(); ++j) {
        const auto& p = ps[static_cast<std::size_t>(j)];
        psi_(j, i) = p.lo + (p.hi - p.lo) * smc::uniform01(rng);
      }
    }
  }
  extension_scale_ = 1.0;
  stiffness_scale_ = 1.0;
  interweave_scale_ = 1.0;
  latents_.resize(0, options_.particles);
  ssr_.resize(0, options_.particles);
  sums_.setZero();
  speed_mps_.clear();
  sprung_mass_kg_.clear();
  observed_if_.clear();
  older_scale_.clear();
  newest_from_proposals_ = false;
}

void FleetTarget::add_truck(const records::WimRecord& record, const smc::RngFactory& rngs,
                            const smc::ParallelFor& parallel) {
  if (record.impact_factor.size() != sensors_) {
    throw DataError("truck '" + record.truck_id + "' has " + std::to_string(record.impact_factor.size()) +
                    " impact factors but the site has " + std::to_string(sensors_) + " sensors");
  }
  const Eigen::Index n = kept_trucks();
  speed_mps_.push_back(record.speed_mps);
  sprung_mass_kg_.push_back(record.sprung_mass_kg);
  observed_if_.push_back(record.impact_factor);
  latents_.conservativeResize(3 * (n + 1), Eigen::NoChange);
  ssr_.conservativeResize(n + 1, Eigen::NoChange);
  const Eigen::Index P = options_.particles;
  newest_from_proposals_ = options_.proposals != nullptr;
  if (!newest_from_proposals_) {
    for (Eigen::Index i = 0; i < P; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      prior_latents(i, rng, latents_.col(i).data() + 3 * n);
    }
    Eigen::ArrayXd ssr(P);
    residuals(n, latents_.middleRows(3 * n, 3), ssr, parallel);
    ssr_.row(n) = ssr.matrix().transpose();
  } else {
    draw_newest_from_proposals(record, rngs, parallel);
  }
  older_scale_.resize(static_cast<std::size_t>(n), 1.0);  // the truck that was newest joins the older ones
  // The previous newest truck is an older one now: fold it into the running sums.
  for (Eigen::Index i = 0; i < P; ++i) recompute_sums(i);
}

void FleetTarget::prior_latents(Eigen::Index i, smc::Rng& rng, double* x) const {
  const HyperVector t = theta_of(i);
  x[kStiffness] = draw_stiffness(rng, t, psi_.col(i).data());
  x[kTyreStiffness] = t[kKt] + t[kSigmaKt] * standard_normal(rng);
  // z ~ N(Z, σ_z²) truncated to the road: the prior box keeps at least ~45 % of the mass on it,
  // so rejection is cheap.
  double z = t[kZ] + t[kSigmaZ] * standard_normal(rng);
  while (z < lateral_.lo_m || z > lateral_.hi_m) z = t[kZ] + t[kSigmaZ] * standard_normal(rng);
  x[kLateral] = z;
}

void FleetTarget::draw_newest_from_proposals(const records::WimRecord& record, const smc::RngFactory& rngs,
                                             const smc::ParallelFor& parallel) {
  const Eigen::Index P = options_.particles, newest = kept_trucks() - 1, m = options_.proposal_draws;
  const auto arrival = static_cast<std::size_t>(kept_trucks() - 1);
  if (!options_.proposals->matches(arrival, record.speed_mps, record.sprung_mass_kg)) {
    throw UsageError("fleet target: truck '" + record.truck_id + "' (#" + std::to_string(kept_trucks()) +
                     ") is not the truck its proposals were built for (another log, or another order)");
  }
  const double log_table_share = std::log1p(-options_.defensive_share), log_prior_share = std::log(options_.defensive_share);
  Eigen::MatrixXd x(3, P * m);
  Eigen::ArrayXd log_w(P * m), ssr(P * m), pick(P);
  newest_log_zhat_.resize(P);
  // Each particle's proposal depends on its own θ and its draws come from its own stream, and
  // each chunk simulates its own draws: the split over threads changes nothing.
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<SsrJob> jobs;
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      pick[i] = smc::uniform01(rng);
      const HyperVector t = theta_of(i);
      const double* psi = psi_.col(i).data();
      const auto table = options_.proposals->proposal(arrival, t);
      for (Eigen::Index j = i * m; j < (i + 1) * m; ++j) {
        double* xj = x.col(j).data();
        if (!table || smc::uniform01(rng) < options_.defensive_share) {
          prior_latents(i, rng, xj);
        } else {
          const model::TruckLatent drawn = table->draw(rng);
          xj[kStiffness] = drawn.stiffness_npm;
          xj[kTyreStiffness] = drawn.tyre_stiffness_npm;
          xj[kLateral] = drawn.lateral_m;
        }
        const double log_prior = latent_log_density(xj, t, psi);
        double log_q = log_prior;
        if (table) {
          const double a = log_table_share + table->log_density({xj[kStiffness], xj[kTyreStiffness], xj[kLateral]});
          const double b = log_prior_share + log_prior;
          const double top = std::max(a, b);  // finite: x was drawn from one of the two parts
          log_q = top + std::log(std::exp(a - top) + std::exp(b - top));
        }
        log_w[j] = log_prior > -kInf ? log_prior - log_q : -kInf;
        jobs.push_back({newest, xj, &ssr[j], psi});
      }
    }
    simulate_ssr(jobs);
    for (Eigen::Index i = begin; i < end; ++i) {
      const double sigma_if = theta_(kSigmaIf, i);
      double top = -kInf;
      for (Eigen::Index j = i * m; j < (i + 1) * m; ++j) {
        if (log_w[j] > -kInf) log_w[j] += newest_loglik(ssr[j], sigma_if);
        top = std::max(top, log_w[j]);
      }
      Eigen::Index chosen = i * m;
      if (!(top > -kInf)) {
        newest_log_zhat_[i] = -kInf;  // no draw the truck's data allow: the particle dies
      } else {
        double total = 0.0;
        for (Eigen::Index j = i * m; j < (i + 1) * m; ++j) total += std::exp(log_w[j] - top);
        newest_log_zhat_[i] = top + std::log(total / static_cast<double>(m));
        // k ∝ w_k, by inversion of the one uniform drawn first.
        double below = 0.0;
        for (Eigen::Index j = i * m; j < (i + 1) * m; ++j) {
          chosen = j;
          below += std::exp(log_w[j] - top) / total;
          if (pick[i] < below) break;
        }
      }
      latents_.block(3 * newest, i, 3, 1) = x.col(chosen);
      ssr_(newest, i) = ssr[chosen];
    }
  });
  passes_ += P * m;
}

Eigen::MatrixXd FleetTarget::truck_latents(Eigen::Index truck) const { return latents_.middleRows(3 * truck, 3); }

void FleetTarget::recompute_sums(Eigen::Index i) {
  double s[kSumCount];
  for (double& v : s) v = 0.0;
  for (Eigen::Index j = 0; j + 1 < kept_trucks(); ++j) {
    const double k = latents_(3 * j + kStiffness, i), kt = latents_(3 * j + kTyreStiffness, i),
                 z = latents_(3 * j + kLateral, i);
    s[kSumK] += k;
    s[kSumK2] += k * k;
    s[kSumKt] += kt;
    s[kSumKt2] += kt * kt;
    s[kSumZ] += z;
    s[kSumZ2] += z * z;
    s[kSumSsr] += ssr_(j, i);
  }
  for (int c = 0; c < kSumCount; ++c) sums_(c, i) = s[c];
}

bool FleetTarget::stiffness_edited() const { return edits_stiffness(options_.extension); }

double FleetTarget::draw_stiffness(smc::Rng& rng, const HyperVector& t, const double* psi) const {
  if (!stiffness_edited()) return t[kK] + t[kSigmaK] * standard_normal(rng);
  const double u = smc::uniform01(rng);  // drawn first: the order fixes the stream
  return options_.extension->draw_stiffness(psi, t[kK], t[kSigmaK], u, standard_normal(rng));
}

double FleetTarget::latent_log_density(const double* x, const HyperVector& t, const double* psi) const {
  return log_latent_density(options_.extension, psi, x[kStiffness], x[kTyreStiffness], x[kLateral], t, lateral_);
}

double FleetTarget::stiffness_log_density(Eigen::Index i, double mean, double sd, const double* psi,
                                          Eigen::Index trucks) const {
  return log_stiffness_sum(*options_.extension, psi, latents_.col(i).data() + kStiffness, trucks, 3, mean, sd);
}

double FleetTarget::base_density(Eigen::Index i, const HyperVector& t, const double* newest) const {
  const double older = older_density(i, t);
  if (!(older > -kInf)) return older;
  return older + latent_log_density(newest, t, psi_.col(i).data());
}

double FleetTarget::older_density(Eigen::Index i, const HyperVector& t) const {
  const double* s = sums_.col(i).data();
  const double* psi = psi_.col(i).data();
  // The prior is uniform on a box: its log density inside is one constant (log_prior_inside_).
  if (!options_.prior.contains(t)) return -kInf;
  double lp = log_prior_inside_;
  const double n = static_cast<double>(trucks() - 1);
  if (n > 0) {
    // With an extension's stiffness distribution there is no sufficient statistic: every older
    // truck's k is in (the exact regime keeps them all).
    lp += stiffness_edited() ? stiffness_log_density(i, t[kK], t[kSigmaK], psi, kept_trucks() - 1)
                             : log_normal_sum({n, s[kSumK], s[kSumK2]}, t[kK], t[kSigmaK]);
    lp += log_normal_sum({n, s[kSumKt], s[kSumKt2]}, t[kKt], t[kSigmaKt]);
    lp += log_lateral_sum({n, s[kSumZ], s[kSumZ2]}, t[kZ], t[kSigmaZ], lateral_);
    lp += log_noise_sum(n * sensors_, s[kSumSsr], t[kSigmaIf]);
  }
  return lp;
}

double FleetTarget::newest_loglik(double ssr, double sigma_if) const {
  if (!std::isfinite(ssr)) return -kInf;
  return log_likelihood_from_ssr(ssr, sensors_, sigma_if);
}

void FleetTarget::simulate_ssr(const std::vector<SsrJob>& jobs) const {
  // Only physical states are simulated; the rest get an infinite SSR (likelihood zero).
  std::vector<const SsrJob*> physical;
  physical.reserve(jobs.size());
  for (const auto& job : jobs) {
    const double k = job.latents[kStiffness], kt = job.latents[kTyreStiffness], z = job.latents[kLateral];
    if (k > 0.0 && kt > 0.0 && z >= lateral_.lo_m && z <= lateral_.hi_m) physical.push_back(&job);
    else *job.ssr_out = kInf;
  }
  if (physical.empty()) return;
  if (options_.extension != nullptr && options_.extension->edits_forward()) {
    std::vector<ExtendedPass> passes;
    passes.reserve(physical.size());
    for (const SsrJob* job : physical) {
      const auto truck = static_cast<std::size_t>(job->truck);
      passes.push_back({base_pass(site_, speed_mps_[truck], sprung_mass_kg_[truck], job->latents[kStiffness],
                                  job->latents[kTyreStiffness], job->latents[kLateral]),
                        job->psi});
    }
    Eigen::ArrayXXd model_if(sensors_, static_cast<Eigen::Index>(passes.size()));
    simulate_passes(site_, options_.extension, passes, model_if);
    for (std::size_t q = 0; q < physical.size(); ++q) {
      const auto& y = observed_if_[static_cast<std::size_t>(physical[q]->truck)];
      *physical[q]->ssr_out = (model_if.col(static_cast<Eigen::Index>(q)) - y.array()).square().sum();
    }
    return;
  }
  site::TruckBatch batch;
  batch.resize(static_cast<Eigen::Index>(physical.size()));
  for (std::size_t q = 0; q < physical.size(); ++q) {
    const auto b = static_cast<Eigen::Index>(q);
    const auto truck = static_cast<std::size_t>(physical[q]->truck);
    batch.speed_mps[b] = speed_mps_[truck];
    batch.sprung_mass_kg[b] = sprung_mass_kg_[truck];
    batch.stiffness_npm[b] = physical[q]->latents[kStiffness];
    batch.tyre_stiffness_npm[b] = physical[q]->latents[kTyreStiffness];
    batch.lateral_m[b] = physical[q]->latents[kLateral];
  }
  Eigen::ArrayXXd model_if(sensors_, batch.size());
  site_.impact_factors(batch, model_if);
  for (std::size_t q = 0; q < physical.size(); ++q) {
    const auto& y = observed_if_[static_cast<std::size_t>(physical[q]->truck)];
    *physical[q]->ssr_out = (model_if.col(static_cast<Eigen::Index>(q)) - y.array()).square().sum();
  }
}

Eigen::MatrixXd FleetTarget::every_kept_truck_ssr(const Eigen::MatrixXd& latents, const Eigen::MatrixXd& psi,
                                                  const std::vector<char>& inside, const smc::ParallelFor& parallel) {
  const Eigen::Index P = options_.particles, n = kept_trucks();
  Eigen::MatrixXd ssr = Eigen::MatrixXd::Constant(n, P, std::numeric_limits<double>::infinity());
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<SsrJob> jobs;
    for (Eigen::Index i = begin; i < end; ++i) {
      if (!inside[static_cast<std::size_t>(i)]) continue;
      for (Eigen::Index j = 0; j < n; ++j) jobs.push_back({j, latents.col(i).data() + 3 * j, &ssr(j, i), psi.col(i).data()});
    }
    simulate_ssr(jobs);
  });
  passes_ += n * static_cast<long long>(std::count(inside.begin(), inside.end(), 1));
  return ssr;
}

void FleetTarget::residuals(Eigen::Index truck, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                            Eigen::Ref<Eigen::ArrayXd> ssr_out, const smc::ParallelFor& parallel) {
  parallel(latents.cols(), [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<SsrJob> jobs;
    for (Eigen::Index i = begin; i < end; ++i) jobs.push_back({truck, latents.col(i).data(), &ssr_out[i], psi_.col(i).data()});
    simulate_ssr(jobs);
  });
  passes_ += latents.cols();
}

void FleetTarget::log_density(Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                              const smc::ParallelFor& parallel) {
  const Eigen::Index newest = kept_trucks() - 1;
  parallel(options_.particles, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const HyperVector t = theta_of(i);
      if (newest_from_proposals_) {
        // The stage's extended target (Options::proposals): log γ holds no term of the newest
        // truck that any move below φ = 1 reads, and ℓ is its estimated marginal likelihood.
        log_base[i] = older_density(i, t);
        loglik[i] = newest_log_zhat_[i];
      } else {
        log_base[i] = base_density(i, t, latents_.col(i).data() + 3 * newest);
        loglik[i] = newest_loglik(ssr_(newest, i), t[kSigmaIf]);
      }
    }
  });
}

std::vector<smc::BlockSpec> FleetTarget::blocks() const {
  // With proposals the stage's target below φ = 1 is an extended one (Options::proposals) that a
  // random walk on the newest truck's latents alone would not keep: that truck is moved with
  // the older ones from the next stage on.
  if (newest_from_proposals_) return {};
  return {{"truck " + std::to_string(trucks()) + " (newest)", 3}};
}

void FleetTarget::get_block(int /*block*/, Eigen::Ref<Eigen::MatrixXd> values) const {
  values = latents_.middleRows(3 * (kept_trucks() - 1), 3);
}

void FleetTarget::log_density_at(int /*block*/, const Eigen::Ref<const Eigen::MatrixXd>& proposed,
                                 Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                                 const smc::ParallelFor& parallel) {
  const Eigen::Index P = options_.particles;
  proposed_ssr_.resize(P);
  residuals(kept_trucks() - 1, proposed, proposed_ssr_, parallel);
  // Each particle's densities are its own: the chunks' results do not depend on the split.
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const HyperVector t = theta_of(i);
      log_base[i] = base_density(i, t, proposed.col(i).data());
      loglik[i] = newest_loglik(proposed_ssr_[i], t[kSigmaIf]);
    }
  });
}

void FleetTarget::accept(int /*block*/, const std::vector<char>& accepted,
                         const Eigen::Ref<const Eigen::MatrixXd>& proposed) {
  const Eigen::Index newest = kept_trucks() - 1;
  for (Eigen::Index i = 0; i < options_.particles; ++i) {
    if (!accepted[static_cast<std::size_t>(i)]) continue;
    latents_.block(3 * newest, i, 3, 1) = proposed.col(i);
    ssr_(newest, i) = proposed_ssr_[i];
  }
}

void FleetTarget::resample(const std::vector<Eigen::Index>& ancestors) {
  theta_ = theta_(Eigen::all, ancestors).eval();
  psi_ = psi_(Eigen::all, ancestors).eval();
  latents_ = latents_(Eigen::all, ancestors).eval();
  ssr_ = ssr_(Eigen::all, ancestors).eval();
  sums_ = sums_(Eigen::all, ancestors).eval();
  if (newest_from_proposals_) newest_log_zhat_ = newest_log_zhat_(ancestors).eval();
}

}  // namespace ssrfleet::fleet
