#include "fleet/fleet_target.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <string>

#include "model/extended_forward.hpp"
#include "model/truncated_samplers.hpp"
#include "smc/mh_kernel.hpp"
#include "smc/rng.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// The one engine MH block: the newest truck's latents.
constexpr int kNewestBlock = 0;

// Standard normal by Box-Muller on the counter-based stream (fixed forever, like uniform01).
double standard_normal(smc::Rng& rng) {
  double u1 = smc::uniform01(rng);
  while (u1 <= 0.0) u1 = smc::uniform01(rng);
  const double u2 = smc::uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

// Sum over n draws of log N(x; mean, sd) from Σx and Σx².
double sum_log_normal(double n, double sum, double sum2, double mean, double sd) {
  const double squares = sum2 - 2.0 * mean * sum + n * mean * mean;
  return -0.5 * n * kLog2Pi - n * std::log(sd) - squares / (2.0 * sd * sd);
}
}  // namespace

FleetTarget::FleetTarget(const site::Site& site, Options options)
    : site_(site), options_(options), lateral_{site.lateral_min_m(), site.lateral_max_m()},
      sensors_(site.sensors()), log_prior_inside_(options.prior.log_prior(options.prior.lo)) {
  if (options_.particles < 2) {
    throw UsageError("fleet target: particles is " + std::to_string(options_.particles) + ", but must be at least 2");
  }
  if (options_.older_sweeps < 0) throw UsageError("fleet target: older_sweeps must be >= 0");
  if (options_.window < 0) throw UsageError("fleet target: window must be >= 0");
  if (options_.extension != nullptr && options_.window > 0) {
    throw UsageError("fleet target: a model extension needs the exact regime (window 0)");
  }
  if (options_.extension_sweeps < 0) throw UsageError("fleet target: extension_sweeps must be >= 0");
  if (options_.extension_jump_sweeps < 0) throw UsageError("fleet target: extension_jump_sweeps must be >= 0");
  theta_.resize(kHyperCount, options_.particles);
  psi_.resize(options_.extension != nullptr ? options_.extension->dim() : 0, options_.particles);
  sums_ = Eigen::MatrixXd::Zero(kSumCount, options_.particles);
  retired_ = Eigen::MatrixXd::Zero(kSumCount, options_.particles);
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
  latents_.resize(0, options_.particles);
  ssr_.resize(0, options_.particles);
  sums_.setZero();
  retired_.setZero();
  total_trucks_ = 0;
  speed_mps_.clear();
  sprung_mass_kg_.clear();
  observed_if_.clear();
  pool_speed_mps_.clear();
  pool_sprung_mass_kg_.clear();
  older_scale_.clear();
}

void FleetTarget::add_truck(const records::WimRecord& record, const smc::RngFactory& rngs,
                            const smc::ParallelFor& parallel) {
  if (record.impact_factor.size() != sensors_) {
    throw DataError("truck '" + record.truck_id + "' has " + std::to_string(record.impact_factor.size()) +
                    " impact factors but the site has " + std::to_string(sensors_) + " sensors");
  }
  const Eigen::Index n = kept_trucks();
  ++total_trucks_;
  pool_speed_mps_.push_back(record.speed_mps);
  pool_sprung_mass_kg_.push_back(record.sprung_mass_kg);
  if (options_.window > 0 && pool_speed_mps_.size() > kPredictionPool) {
    pool_speed_mps_.pop_front();
    pool_sprung_mass_kg_.pop_front();
  }
  speed_mps_.push_back(record.speed_mps);
  sprung_mass_kg_.push_back(record.sprung_mass_kg);
  observed_if_.push_back(record.impact_factor);
  latents_.conservativeResize(3 * (n + 1), Eigen::NoChange);
  ssr_.conservativeResize(n + 1, Eigen::NoChange);
  const Eigen::Index P = options_.particles;
  for (Eigen::Index i = 0; i < P; ++i) {
    smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
    const HyperVector t = theta_of(i);
    latents_(3 * n + kStiffness, i) = draw_stiffness(rng, t, psi_.col(i).data());
    latents_(3 * n + kTyreStiffness, i) = t[kKt] + t[kSigmaKt] * standard_normal(rng);
    // z ~ N(Z, σ_z²) truncated to the road: the prior box keeps at least ~45 % of the mass on it,
    // so rejection is cheap.
    double z = t[kZ] + t[kSigmaZ] * standard_normal(rng);
    while (z < lateral_.lo_m || z > lateral_.hi_m) z = t[kZ] + t[kSigmaZ] * standard_normal(rng);
    latents_(3 * n + kLateral, i) = z;
  }
  Eigen::ArrayXd ssr(P);
  residuals(n, latents_.middleRows(3 * n, 3), ssr, parallel);
  ssr_.row(n) = ssr.matrix().transpose();
  older_scale_.resize(static_cast<std::size_t>(n), 1.0);  // the truck that was newest joins the older ones
  if (options_.window > 0 && kept_trucks() > options_.window + 1) retire_oldest_kept_truck();
  // The previous newest truck is an older one now: fold it into the running sums.
  for (Eigen::Index i = 0; i < P; ++i) recompute_sums(i);
  older_sweeps_done_ = 0;
  extension_sweeps_done_ = 0;
}

void FleetTarget::retire_oldest_kept_truck() {
  for (Eigen::Index i = 0; i < options_.particles; ++i) {
    const double k = latents_(kStiffness, i), kt = latents_(kTyreStiffness, i), z = latents_(kLateral, i);
    retired_(kSumK, i) += k;
    retired_(kSumK2, i) += k * k;
    retired_(kSumKt, i) += kt;
    retired_(kSumKt2, i) += kt * kt;
    retired_(kSumZ, i) += z;
    retired_(kSumZ2, i) += z * z;
    retired_(kSumSsr, i) += ssr_(0, i);
  }
  latents_ = latents_.bottomRows(latents_.rows() - 3).eval();
  ssr_ = ssr_.bottomRows(ssr_.rows() - 1).eval();
  speed_mps_.erase(speed_mps_.begin());
  sprung_mass_kg_.erase(sprung_mass_kg_.begin());
  observed_if_.erase(observed_if_.begin());
  older_scale_.erase(older_scale_.begin());
}

Eigen::MatrixXd FleetTarget::truck_latents(Eigen::Index truck) const { return latents_.middleRows(3 * truck, 3); }

void FleetTarget::recompute_sums(Eigen::Index i) {
  double s[kSumCount];
  for (int c = 0; c < kSumCount; ++c) s[c] = retired_(c, i);
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

bool FleetTarget::stiffness_edited() const {
  return options_.extension != nullptr && options_.extension->edits_stiffness_distribution();
}

double FleetTarget::draw_stiffness(smc::Rng& rng, const HyperVector& t, const double* psi) const {
  if (!stiffness_edited()) return t[kK] + t[kSigmaK] * standard_normal(rng);
  const double u = smc::uniform01(rng);  // drawn first: the order fixes the stream
  return options_.extension->draw_stiffness(psi, t[kK], t[kSigmaK], u, standard_normal(rng));
}

double FleetTarget::latent_log_density(const double* x, const HyperVector& t, const double* psi) const {
  if (!stiffness_edited()) return log_latent_density(x[kStiffness], x[kTyreStiffness], x[kLateral], t, lateral_);
  // The base density with the k factor swapped for the extension's.
  return log_latent_density(x[kStiffness], x[kTyreStiffness], x[kLateral], t, lateral_) -
         log_normal_density(x[kStiffness], t[kK], t[kSigmaK]) +
         options_.extension->log_stiffness_density(psi, x[kStiffness], t[kK], t[kSigmaK]);
}

double FleetTarget::stiffness_log_density(Eigen::Index i, double mean, double sd, const double* psi,
                                          Eigen::Index trucks) const {
  double lp = 0.0;
  for (Eigen::Index j = 0; j < trucks; ++j) {
    lp += options_.extension->log_stiffness_density(psi, latents_(3 * j + kStiffness, i), mean, sd);
  }
  return lp;
}

double FleetTarget::base_density(Eigen::Index i, const HyperVector& t, const double* newest) const {
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
                             : sum_log_normal(n, s[kSumK], s[kSumK2], t[kK], t[kSigmaK]);
    lp += sum_log_normal(n, s[kSumKt], s[kSumKt2], t[kKt], t[kSigmaKt]);
    lp += sum_log_normal(n, s[kSumZ], s[kSumZ2], t[kZ], t[kSigmaZ]) -
          n * log_normal_mass(lateral_.lo_m, lateral_.hi_m, t[kZ], t[kSigmaZ]);
    const double nm = n * sensors_;
    lp += -0.5 * nm * kLog2Pi - nm * std::log(t[kSigmaIf]) - s[kSumSsr] / (2.0 * t[kSigmaIf] * t[kSigmaIf]);
  }
  return lp + latent_log_density(newest, t, psi);
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
      log_base[i] = base_density(i, t, latents_.col(i).data() + 3 * newest);
      loglik[i] = newest_loglik(ssr_(newest, i), t[kSigmaIf]);
    }
  });
}

std::vector<smc::BlockSpec> FleetTarget::blocks() const {
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
  retired_ = retired_(Eigen::all, ancestors).eval();
}

void FleetTarget::custom_moves(double phi, const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                               Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik) {
  if (phi == 1.0 && older_sweeps_done_ < options_.older_sweeps && kept_trucks() >= 2) {
    // Alternate a random walk on (k, k_t, z) with an independence proposal of (k, k_t) from
    // p(k, k_t | θ): one truck's data say little about its stiffnesses, so the prior proposal
    // is accepted often and moves them across their whole range, which the spread parameters
    // σ_k and σ_kt need (a random walk alone left them 0.4 posterior sd off a long MCMC).
    older_trucks_sweep(rngs.child(1), parallel, older_sweeps_done_ % 2 == 1, kept_trucks() - 1, older_scale_);
    ++older_sweeps_done_;
  }
  if (phi == 1.0 && options_.extension != nullptr && options_.extension->edits_forward()) {
    // Per stage: the jump sweeps (if the extension has a jump), then the random-walk sweeps.
    const int jumps = options_.extension->jump_draws() > 0 ? options_.extension_jump_sweeps : 0;
    if (extension_sweeps_done_ < jumps) {
      extension_sweep(rngs.child(3), parallel, PsiMove::kJump);
      ++extension_sweeps_done_;
    } else if (extension_sweeps_done_ < jumps + options_.extension_sweeps) {
      extension_sweep(rngs.child(2), parallel, PsiMove::kRandomWalk);
      ++extension_sweeps_done_;
    }
  }
  if (stiffness_edited()) stiffness_distribution_sweep(rngs.child(4), parallel);
  theta_moves(phi, rngs.child(0), parallel, log_base, loglik);
}

void FleetTarget::rejuvenate(int sweeps, const smc::RngFactory& rngs, const smc::ParallelFor& parallel) {
  if (sweeps < 0) throw UsageError("fleet target: rejuvenation sweeps must be >= 0");
  if (kept_trucks() == 0) return;
  // The newest truck's proposal scale starts at 1 and adapts within this call; the older ones
  // carry on from the stages.
  std::vector<double> scales = older_scale_;
  scales.push_back(1.0);
  Eigen::ArrayXd log_base(options_.particles), loglik(options_.particles);  // not needed after φ = 1
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const smc::RngFactory r = rngs.child(static_cast<std::uint64_t>(sweep));
    older_trucks_sweep(r.child(1), parallel, sweep % 2 == 1, kept_trucks(), scales);
    if (options_.extension != nullptr && options_.extension->edits_forward()) {
      extension_sweep(r.child(2), parallel, PsiMove::kRandomWalk);
    }
    if (stiffness_edited()) stiffness_distribution_sweep(r.child(4), parallel);
    theta_moves(1.0, r.child(0), parallel, log_base, loglik);
  }
  scales.pop_back();
  older_scale_ = scales;
}

void FleetTarget::theta_moves(double phi, const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                              Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik) {
  const Eigen::Index newest = kept_trucks() - 1;
  const double n_all = static_cast<double>(trucks());  // the newest truck's latents are in γ in full
  const auto& prior = options_.prior;
  parallel(options_.particles, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      HyperVector t = theta_of(i);
      const double* s = sums_.col(i).data();
      const double* x = latents_.col(i).data() + 3 * newest;
      // Sums over all n+1 latents (older ones from the running sums, plus the newest).
      const double sk = s[kSumK] + x[kStiffness], sk2 = s[kSumK2] + x[kStiffness] * x[kStiffness];
      const double skt = s[kSumKt] + x[kTyreStiffness], skt2 = s[kSumKt2] + x[kTyreStiffness] * x[kTyreStiffness];
      // (K, σ_k) have standard conditionals only under the base model's N(K, σ_k²); an extension's
      // stiffness distribution moves them in stiffness_distribution_sweep instead.
      if (!stiffness_edited()) t[kK] = draw_truncated_normal(rng, sk / n_all, t[kSigmaK] / std::sqrt(n_all), prior.lo[kK], prior.hi[kK]);
      t[kKt] = draw_truncated_normal(rng, skt / n_all, t[kSigmaKt] / std::sqrt(n_all), prior.lo[kKt], prior.hi[kKt]);
      if (trucks() >= 2) {
        const double ssk = std::max(0.0, sk2 - 2.0 * t[kK] * sk + n_all * t[kK] * t[kK]);
        const double sskt = std::max(0.0, skt2 - 2.0 * t[kKt] * skt + n_all * t[kKt] * t[kKt]);
        if (!stiffness_edited()) t[kSigmaK] = draw_scale_given_sum_squares(rng, static_cast<int>(n_all), ssk, prior.lo[kSigmaK], prior.hi[kSigmaK]);
        t[kSigmaKt] = draw_scale_given_sum_squares(rng, static_cast<int>(n_all), sskt, prior.lo[kSigmaKt], prior.hi[kSigmaKt]);
      }
      // (Z, σ_z): the Gaussian part of their conditional is standard; the truncation to the road
      // adds m(Z, σ_z)^-N (m = the road's share of N(Z, σ_z²)). Propose from the Gaussian part
      // on the prior box and accept with the ratio of m^-N: exact MH, accepting almost always.
      const double sz = s[kSumZ] + x[kLateral], sz2 = s[kSumZ2] + x[kLateral] * x[kLateral];
      const auto log_mass = [&](double mean, double sd) {
        return log_normal_mass(lateral_.lo_m, lateral_.hi_m, mean, sd);
      };
      {
        const double z_new = draw_truncated_normal(rng, sz / n_all, t[kSigmaZ] / std::sqrt(n_all), prior.lo[kZ], prior.hi[kZ]);
        const double log_accept = n_all * (log_mass(t[kZ], t[kSigmaZ]) - log_mass(z_new, t[kSigmaZ]));
        if (std::log(uniform_open01(rng)) < log_accept) t[kZ] = z_new;
      }
      if (trucks() >= 2) {
        const double ssz = std::max(0.0, sz2 - 2.0 * t[kZ] * sz + n_all * t[kZ] * t[kZ]);
        const double sd_new = draw_scale_given_sum_squares(rng, static_cast<int>(n_all), ssz, prior.lo[kSigmaZ], prior.hi[kSigmaZ]);
        const double log_accept = n_all * (log_mass(t[kZ], t[kSigmaZ]) - log_mass(t[kZ], sd_new));
        if (std::log(uniform_open01(rng)) < log_accept) t[kSigmaZ] = sd_new;
      }
      // σ_IF: older trucks' likelihoods count in full, the newest one's at power φ, so the
      // precision is Gamma((M(n+φ) - 1)/2, (ΣSSR + φ SSR_new)/2) on the box.
      const double ssr_new = ssr_(newest, i);
      if (std::isfinite(ssr_new) && std::isfinite(s[kSumSsr])) {
        const double a = sensors_ * (n_all - 1.0 + phi);
        const double shape = 0.5 * (a - 1.0), rate = 0.5 * (s[kSumSsr] + phi * ssr_new);
        if (shape > 0.0 && rate > 0.0) {
          const double lo_sd = prior.lo[kSigmaIf], hi_sd = prior.hi[kSigmaIf];
          const double tau = draw_truncated_gamma(rng, shape, rate, 1.0 / (hi_sd * hi_sd), 1.0 / (lo_sd * lo_sd));
          t[kSigmaIf] = std::clamp(1.0 / std::sqrt(tau), lo_sd, hi_sd);
        }
      }
      for (int j = 0; j < kHyperCount; ++j) theta_(j, i) = t[j];
      log_base[i] = base_density(i, t, x);
      loglik[i] = newest_loglik(ssr_new, t[kSigmaIf]);
    }
  });
}

void FleetTarget::save(BinaryWriter& out) const {
  out.value<std::int64_t>(options_.particles);
  out.value<std::int32_t>(sensors_);
  out.value<std::int64_t>(options_.window);
  out.value<std::int64_t>(total_trucks_);
  out.matrix(retired_);
  out.value<std::uint64_t>(pool_speed_mps_.size());
  for (std::size_t j = 0; j < pool_speed_mps_.size(); ++j) {
    out.value(pool_speed_mps_[j]);
    out.value(pool_sprung_mass_kg_[j]);
  }
  out.value<std::int64_t>(kept_trucks());
  for (Eigen::Index j = 0; j < kept_trucks(); ++j) {
    out.value(speed_mps_[static_cast<std::size_t>(j)]);
    out.value(sprung_mass_kg_[static_cast<std::size_t>(j)]);
    out.matrix(observed_if_[static_cast<std::size_t>(j)]);
  }
  out.matrix(theta_);
  out.matrix(latents_);
  out.matrix(ssr_);
  out.value<std::uint64_t>(older_scale_.size());
  for (double v : older_scale_) out.value(v);
  if (psi_.rows() > 0) {  // only with an extension, so checkpoints without one keep their format
    out.matrix(psi_);
    out.value(extension_scale_);
    out.value(stiffness_scale_);
  }
}

void FleetTarget::load(BinaryReader& in) {
  const Eigen::Index P = options_.particles;
  if (in.value<std::int64_t>("particles") != P) in.fail("particles", "saved with another particle count");
  if (in.value<std::int32_t>("sensors") != sensors_) in.fail("sensors", "saved for another sensor count");
  if (in.value<std::int64_t>("window") != options_.window) in.fail("window", "saved with another --window");
  total_trucks_ = in.value<std::int64_t>("total_trucks");
  retired_ = in.matrix("retired", kSumCount, P);
  const auto pool = in.value<std::uint64_t>("pool");
  if (pool > static_cast<std::uint64_t>(total_trucks_)) in.fail("pool", "larger than the trucks absorbed");
  pool_speed_mps_.clear();
  pool_sprung_mass_kg_.clear();
  for (std::uint64_t j = 0; j < pool; ++j) {
    pool_speed_mps_.push_back(in.value<double>("pool_speed_mps"));
    pool_sprung_mass_kg_.push_back(in.value<double>("pool_sprung_mass_kg"));
  }
  const auto n = in.value<std::int64_t>("trucks");
  if (n > total_trucks_) in.fail("trucks", "more kept trucks than absorbed");
  if (n < 0 || n > 100'000'000) in.fail("trucks", "implausible truck count");
  speed_mps_.clear();
  sprung_mass_kg_.clear();
  observed_if_.clear();
  for (std::int64_t j = 0; j < n; ++j) {
    speed_mps_.push_back(in.value<double>("speed_mps"));
    sprung_mass_kg_.push_back(in.value<double>("sprung_mass_kg"));
    observed_if_.push_back(in.matrix("impact_factor", sensors_, 1));
  }
  theta_ = in.matrix("theta", kHyperCount, P);
  latents_ = in.matrix("latents", 3 * n, P);
  ssr_ = in.matrix("ssr", n, P);
  const auto scales = in.value<std::uint64_t>("older_scale");
  if (scales != static_cast<std::uint64_t>(n > 0 ? n - 1 : 0)) in.fail("older_scale", "size does not match the trucks");
  older_scale_.assign(scales, 1.0);
  for (auto& v : older_scale_) v = in.value<double>("older_scale");
  if (psi_.rows() > 0) {
    psi_ = in.matrix("psi", psi_.rows(), P);
    extension_scale_ = in.value<double>("extension_scale");
    stiffness_scale_ = in.value<double>("stiffness_scale");
  }
  older_sweeps_done_ = 0;
  extension_sweeps_done_ = 0;
  for (Eigen::Index i = 0; i < P; ++i) recompute_sums(i);
}

void FleetTarget::older_trucks_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel,
                                     bool stiffness_from_prior, Eigen::Index swept, std::vector<double>& scales) {
  const Eigen::Index P = options_.particles, older = swept;
  // Per truck: a proposal from the particle cloud's spread of that truck's latents (equal
  // weights: this runs right after a stage, whatever the weights), scaled by 2.38/√3 and by a
  // multiplier adapted on acceptance from stage to stage.
  std::vector<Eigen::Matrix3d> chol(static_cast<std::size_t>(older));
  const Eigen::ArrayXd equal = Eigen::ArrayXd::Constant(P, 1.0);
  for (Eigen::Index j = 0; j < older; ++j) {
    const Eigen::MatrixXd x = latents_.middleRows(3 * j, 3);
    const Eigen::VectorXd mean = x.rowwise().mean();
    const Eigen::MatrixXd centred = x.colwise() - mean;
    Eigen::Matrix3d cov = centred * centred.transpose() / static_cast<double>(P);
    // A ridge keeps a collapsed coordinate movable: 1e-6 of the prior scale of each latent.
    cov.diagonal() += Eigen::Vector3d(1e-6 * 5e4, 1e-6 * 2e5, 1e-6 * 0.5).array().square().matrix();
    const double scale = scales[static_cast<std::size_t>(j)] * 2.38 / std::sqrt(3.0);
    chol[static_cast<std::size_t>(j)] = Eigen::LLT<Eigen::Matrix3d>(cov).matrixL();
    chol[static_cast<std::size_t>(j)] *= scale;
  }
  // Proposals: particle i's draws come from its own stream, truck by truck in order.
  Eigen::MatrixXd proposals(3 * older, P);
  Eigen::ArrayXd log_u(older * P);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      const HyperVector t = theta_of(i);
      for (Eigen::Index j = 0; j < older; ++j) {
        if (stiffness_from_prior) {
          proposals(3 * j + kStiffness, i) = draw_stiffness(rng, t, psi_.col(i).data());
          proposals(3 * j + kTyreStiffness, i) = t[kKt] + t[kSigmaKt] * standard_normal(rng);
          proposals(3 * j + kLateral, i) = latents_(3 * j + kLateral, i);
        } else {
          const Eigen::Vector3d z(standard_normal(rng), standard_normal(rng), standard_normal(rng));
          proposals.block(3 * j, i, 3, 1) = latents_.block(3 * j, i, 3, 1) + chol[static_cast<std::size_t>(j)] * z;
        }
        log_u[i * older + j] = std::log(uniform_open01(rng));
      }
    }
  });
  // Simulate every (particle, older truck) proposal; chunks of particles run in parallel.
  Eigen::MatrixXd new_ssr(older, P);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<SsrJob> jobs;
    for (Eigen::Index i = begin; i < end; ++i) {
      for (Eigen::Index j = 0; j < older; ++j) {
        jobs.push_back({j, proposals.col(i).data() + 3 * j, &new_ssr(j, i), psi_.col(i).data()});
      }
    }
    simulate_ssr(jobs);
  });
  passes_ += older * P;
  // Accept per (particle, truck): only truck j's own terms change, given θ.
  std::vector<char> took(static_cast<std::size_t>(older * P), 0);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const HyperVector t = theta_of(i);
      for (Eigen::Index j = 0; j < older; ++j) {
        if (!std::isfinite(new_ssr(j, i))) continue;
        // With the stiffnesses proposed from p(k, k_t | θ), their density cancels against the
        // proposal's and the MH ratio is the likelihood ratio.
        const auto terms = [&](const double* x, double ssr) {
          const double prior = stiffness_from_prior ? 0.0 : latent_log_density(x, t, psi_.col(i).data());
          return prior + log_likelihood_from_ssr(ssr, sensors_, t[kSigmaIf]);
        };
        const double log_ratio = terms(proposals.col(i).data() + 3 * j, new_ssr(j, i)) -
                                 terms(latents_.col(i).data() + 3 * j, ssr_(j, i));
        if (log_u[i * older + j] < log_ratio) {
          latents_.block(3 * j, i, 3, 1) = proposals.block(3 * j, i, 3, 1);
          ssr_(j, i) = new_ssr(j, i);
          took[static_cast<std::size_t>(i * older + j)] = 1;
        }
      }
      recompute_sums(i);
    }
  });
  if (stiffness_from_prior) {  // the random walk's scale adapts on its own acceptance only
    older_acceptance_ = static_cast<double>(std::count(took.begin(), took.end(), 1)) / static_cast<double>(took.size());
    return;
  }
  // Acceptance per truck (a serial reduction after the loop: the same whatever the threads).
  double total = 0.0;
  for (Eigen::Index j = 0; j < older; ++j) {
    Eigen::Index moved = 0;
    for (Eigen::Index i = 0; i < P; ++i) moved += took[static_cast<std::size_t>(i * older + j)];
    const double rate = static_cast<double>(moved) / static_cast<double>(P);
    auto& scale = scales[static_cast<std::size_t>(j)];
    scale = smc::tuned_scale_factor(scale, rate);
    total += rate;
  }
  older_acceptance_ = total / static_cast<double>(older);
}

void FleetTarget::extension_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel, PsiMove move) {
  const Eigen::Index P = options_.particles, n = kept_trucks(), d = psi_.rows();
  const ModelExtension& ext = *options_.extension;
  // Proposal: the cloud's spread of ψ (equal weights), 2.38/√d, times a multiplier adapted on
  // acceptance; a ridge of 1e-4 of each prior width keeps a collapsed coordinate movable.
  const Eigen::VectorXd mean = psi_.rowwise().mean();
  const Eigen::MatrixXd centred = psi_.colwise() - mean;
  Eigen::MatrixXd cov = centred * centred.transpose() / static_cast<double>(P);
  for (Eigen::Index j = 0; j < d; ++j) {
    const auto& p = ext.parameters()[static_cast<std::size_t>(j)];
    cov(j, j) += std::pow(1e-4 * (p.hi - p.lo), 2);
  }
  Eigen::MatrixXd chol = Eigen::LLT<Eigen::MatrixXd>(cov).matrixL();
  chol *= extension_scale_ * 2.38 / std::sqrt(static_cast<double>(d));
  Eigen::MatrixXd proposals(d, P);
  Eigen::ArrayXd log_u(P);
  std::vector<char> inside(static_cast<std::size_t>(P), 0);
  for (Eigen::Index i = 0; i < P; ++i) {
    smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
    if (move == PsiMove::kJump) {
      std::vector<double> u(static_cast<std::size_t>(ext.jump_draws()));
      for (double& v : u) v = smc::uniform01(rng);
      ext.jump(psi_.col(i).data(), u.data(), proposals.col(i).data());
    } else {
      Eigen::VectorXd z(d);
      for (Eigen::Index j = 0; j < d; ++j) z[j] = standard_normal(rng);
      proposals.col(i) = psi_.col(i) + chol * z;
    }
    log_u[i] = std::log(uniform_open01(rng));
    inside[static_cast<std::size_t>(i)] = ext.in_prior(proposals.col(i).data()) ? 1 : 0;
  }
  // Every kept truck of every particle whose proposal is inside the prior, at the proposal.
  Eigen::MatrixXd new_ssr = Eigen::MatrixXd::Constant(n, P, kInf);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<SsrJob> jobs;
    for (Eigen::Index i = begin; i < end; ++i) {
      if (!inside[static_cast<std::size_t>(i)]) continue;
      for (Eigen::Index j = 0; j < n; ++j) {
        jobs.push_back({j, latents_.col(i).data() + 3 * j, &new_ssr(j, i), proposals.col(i).data()});
      }
    }
    simulate_ssr(jobs);
  });
  passes_ += n * static_cast<long long>(std::count(inside.begin(), inside.end(), 1));
  Eigen::Index moved = 0;
  for (Eigen::Index i = 0; i < P; ++i) {
    if (!inside[static_cast<std::size_t>(i)]) continue;
    // Uniform prior: inside the box, the ratio is the likelihood ratio over every kept truck
    // (the newest included, at φ = 1).
    const double s_new = new_ssr.col(i).sum(), s_old = ssr_.col(i).sum();
    if (!std::isfinite(s_new)) continue;
    const double sigma = theta_(kSigmaIf, i);
    double log_ratio = (s_old - s_new) / (2.0 * sigma * sigma);
    if (stiffness_edited()) {  // ψ also changes the fleet density of every kept truck's k
      const double mean = theta_(kK, i), sd = theta_(kSigmaK, i);
      log_ratio += stiffness_log_density(i, mean, sd, proposals.col(i).data(), n) -
                   stiffness_log_density(i, mean, sd, psi_.col(i).data(), n);
    }
    if (log_u[i] < log_ratio) {
      psi_.col(i) = proposals.col(i);
      ssr_.col(i) = new_ssr.col(i);
      recompute_sums(i);
      ++moved;
    }
  }
  if (move == PsiMove::kJump) {  // the random walk's scale adapts on its own acceptance only
    extension_jump_acceptance_ = static_cast<double>(moved) / static_cast<double>(P);
    return;
  }
  extension_acceptance_ = static_cast<double>(moved) / static_cast<double>(P);
  extension_scale_ = smc::tuned_scale_factor(extension_scale_, extension_acceptance_);
}

void FleetTarget::stiffness_distribution_sweep(const smc::RngFactory& rngs, const smc::ParallelFor& parallel) {
  const ModelExtension& ext = *options_.extension;
  const Eigen::Index P = options_.particles, n = kept_trucks();
  if (n == 0) return;
  const bool with_psi = !ext.edits_forward();  // otherwise ψ moves in extension_sweep, with the likelihood
  const Eigen::Index d = 2 + (with_psi ? psi_.rows() : 0);
  Eigen::MatrixXd state(d, P);  // (K, σ_k[, ψ]) per particle
  state.row(0) = theta_.row(kK);
  state.row(1) = theta_.row(kSigmaK);
  if (with_psi) state.bottomRows(psi_.rows()) = psi_;
  const Eigen::MatrixXd chol =
      Eigen::LLT<Eigen::MatrixXd>(smc::proposal_covariance(state, Eigen::ArrayXd::Ones(P), 2.38 * stiffness_scale_)).matrixL();
  const auto& prior = options_.prior;
  // log p(K, σ_k, ψ | every kept truck's k) up to a constant: the uniform boxes and the trucks'
  // stiffness densities (the newest truck's in full: its latents are in γ at every φ).
  const auto log_density = [&](Eigen::Index i, const Eigen::VectorXd& x) {
    if (!(x[0] >= prior.lo[kK] && x[0] <= prior.hi[kK] && x[1] >= prior.lo[kSigmaK] && x[1] <= prior.hi[kSigmaK])) return -kInf;
    const double* psi = with_psi ? x.data() + 2 : psi_.col(i).data();
    if (with_psi && !ext.in_prior(psi)) return -kInf;
    return stiffness_log_density(i, x[0], x[1], psi, n);
  };
  std::vector<int> moved(static_cast<std::size_t>(P), 0);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    Eigen::VectorXd z(d);
    for (Eigen::Index i = begin; i < end; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      Eigen::VectorXd x = state.col(i);
      double lp = log_density(i, x);
      for (int step = 0; step < kStiffnessSteps; ++step) {
        for (Eigen::Index j = 0; j < d; ++j) z[j] = standard_normal(rng);
        const Eigen::VectorXd y = x + chol * z;
        const double lp_new = log_density(i, y);
        if (std::log(uniform_open01(rng)) < lp_new - lp) {
          x = y;
          lp = lp_new;
          ++moved[static_cast<std::size_t>(i)];
        }
      }
      theta_(kK, i) = x[0];
      theta_(kSigmaK, i) = x[1];
      if (with_psi) psi_.col(i) = x.tail(psi_.rows());
    }
  });
  // A serial reduction: the same whatever the threads.
  double total = 0.0;
  for (int m : moved) total += m;
  stiffness_acceptance_ = total / static_cast<double>(P * kStiffnessSteps);
  stiffness_scale_ = smc::tuned_scale_factor(stiffness_scale_, stiffness_acceptance_);
}

}  // namespace ssrfleet::fleet
