#include "fleet/marginal_target.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// The moves' coordinates: the four scale parameters on the log scale, where the early posterior's
// funnels (a fleet sd near zero against a broad one) become walkable and a random walk scaled on
// the cloud's covariance fits the shape. Uniform priors on σ give a density σ on log σ.
constexpr bool kLogScale[kHyperCount] = {false, true, false, true, false, true, true};

HyperVector from_move_coordinates(const Eigen::Ref<const Eigen::MatrixXd>& x, Eigen::Index p) {
  HyperVector t;
  for (int j = 0; j < kHyperCount; ++j) t[static_cast<std::size_t>(j)] = kLogScale[j] ? std::exp(x(j, p)) : x(j, p);
  return t;
}

double log_jacobian(const HyperVector& t) {
  double s = 0.0;
  for (int j = 0; j < kHyperCount; ++j)
    if (kLogScale[j]) s += std::log(t[static_cast<std::size_t>(j)]);
  return s;
}

// Weighted quantile of one row of the cloud.
double weighted_quantile(const Eigen::Ref<const Eigen::RowVectorXd>& x, const Eigen::ArrayXd& W, double q) {
  std::vector<Eigen::Index> order(static_cast<std::size_t>(x.size()));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  std::sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return x[a] < x[b]; });
  double acc = 0.0;
  for (Eigen::Index i : order) {
    acc += W[i];
    if (acc >= q) return x[i];
  }
  return x[order.back()];
}

}  // namespace

MarginalTarget::MarginalTarget(std::vector<const site::Site*> sites, Options options)
    : sites_(std::move(sites)), options_(std::move(options)), marginal_(model::FleetMarginal(0, {}, {})) {
  if (sites_.empty() || std::find(sites_.begin(), sites_.end(), nullptr) != sites_.end()) {
    throw UsageError("MarginalTarget: needs at least one site");
  }
  marginal_ = make_marginal(model::Lattice{});
  if (options_.particles < 2) throw UsageError("MarginalTarget: particles must be >= 2");
  if (!(options_.lattice_fraction > 0.0 && options_.lattice_fraction <= 1.5)) {
    throw UsageError("MarginalTarget: lattice_fraction must be in (0, 1.5]");
  }
  // A piece narrower than ~1 mm would cost entries for nothing (the road's lines are centimetres
  // apart); a fraction above 1/2 of σ_z would leave the matching error near 1e-2 nats per truck.
  if (!(options_.lateral_piece_fraction > 0.0 && options_.lateral_piece_fraction <= 0.5)) {
    throw UsageError("MarginalTarget: lateral_piece_fraction must be in (0, 0.5]");
  }
  if (!(options_.lattice_sd_quantile > 0.0 && options_.lattice_sd_quantile <= 0.5)) {
    throw UsageError("MarginalTarget: lattice_sd_quantile must be in (0, 0.5]");
  }
  if (!(options_.lattice_sd_min_of_median > 0.0 && options_.lattice_sd_min_of_median <= 1.0)) {
    throw UsageError("MarginalTarget: lattice_sd_min_of_median must be in (0, 1]");
  }
  if (!(options_.min_piece_sd_m >= 1e-3)) throw UsageError("MarginalTarget: min_piece_sd_m must be >= 0.001 m");
  if (!(options_.table.mode_margin_nats >= 0.0)) throw UsageError("MarginalTarget: table.mode_margin_nats must be >= 0");
  theta_.resize(kHyperCount, options_.particles);
  base_sum_ = Eigen::ArrayXd::Zero(options_.particles);
  inc_ = Eigen::ArrayXd::Zero(options_.particles);
  proposed_base_sum_ = inc_;
  proposed_inc_ = inc_;
}

void MarginalTarget::initialise(const smc::RngFactory& rngs) {
  const auto& prior = options_.prior;
  for (Eigen::Index i = 0; i < options_.particles; ++i) {
    smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
    for (int j = 0; j < kHyperCount; ++j) theta_(j, i) = prior.lo[j] + (prior.hi[j] - prior.lo[j]) * smc::uniform01(rng);
  }
  base_sum_.setZero();
  inc_.setZero();
  mode_ = Mode::kIdle;
}

model::FleetMarginal MarginalTarget::make_marginal(const model::Lattice& lattice) const {
  std::vector<model::SiteConstants> constants;
  constants.reserve(sites_.size());
  for (const site::Site* s : sites_) constants.push_back({s->sensors(), {s->lateral_min_m(), s->lateral_max_m()}});
  return model::FleetMarginal(std::move(constants), lattice);
}

void MarginalTarget::check_truck(std::uint32_t site, const Eigen::VectorXd& impact_factors) const {
  if (site >= sites_.size()) {
    throw UsageError("MarginalTarget: a truck of site " + std::to_string(site) + " but the fit has " +
                     std::to_string(sites_.size()) + " site(s)");
  }
  if (impact_factors.size() != site_of(site).sensors()) {
    throw DataError("record", 0, "impact factors",
                    "has " + std::to_string(impact_factors.size()) + " values but the site has " +
                        std::to_string(site_of(site).sensors()) + " sensors");
  }
}

HyperVector MarginalTarget::theta_of(Eigen::Index p) const {
  HyperVector t;
  for (int j = 0; j < kHyperCount; ++j) t[static_cast<std::size_t>(j)] = theta_(j, p);
  return t;
}

double MarginalTarget::sum_loglik(const model::TableStore& store, const model::FleetMarginal& marginal,
                                  std::size_t end, const HyperVector& theta) const {
  const model::ThetaTerms terms = marginal.prepare(theta);
  double s = kNegInf;
  marginal.sum_log_likelihood(store, end, &terms, 1, &s);
  return s;
}

double MarginalTarget::log_posterior(const HyperVector& theta) const {
  const double lp = options_.prior.log_prior(theta);
  if (lp == kNegInf) return lp;
  return lp + sum_loglik(store_, marginal_, store_.trucks(), theta);
}

MarginalTarget::TableSettings MarginalTarget::ideal_settings(const Eigen::ArrayXd& W) const {
  TableSettings s = settings_;
  const Eigen::Index n = trucks();
  // σ_ref: the posterior mean of σ_IF.
  s.sigma_ref = (theta_.row(kSigmaIf).array().transpose() * W).sum();
  // Integrand width in k: the likelihood sd at σ_ref (geometric mean over trucks) combined with
  // the fleet sd (posterior median; particles far below it meet FleetMarginal's floor).
  const double lik_k = std::exp(sum_log_sd_k_ / static_cast<double>(n)) * s.sigma_ref;
  const double lik_kt = std::exp(sum_log_sd_kt_ / static_cast<double>(n)) * s.sigma_ref;
  // The fleet sd the lattice must resolve: a low quantile of its posterior, not the median, so that
  // FleetMarginal's floor (0.8 spacings) sits below the posterior's lower tail (Options); never
  // below a fraction of the median, so a broad early posterior does not make the lattice explode.
  auto resolved_sd = [&](int h) {
    const double median = weighted_quantile(theta_.row(h), W, 0.5);
    return std::max(weighted_quantile(theta_.row(h), W, options_.lattice_sd_quantile),
                    options_.lattice_sd_min_of_median * median);
  };
  const double fleet_k = resolved_sd(kSigmaK);
  const double fleet_kt = resolved_sd(kSigmaKt);
  const double width_k = 1.0 / std::sqrt(1.0 / (lik_k * lik_k) + 1.0 / (fleet_k * fleet_k));
  const double width_kt = 1.0 / std::sqrt(1.0 / (lik_kt * lik_kt) + 1.0 / (fleet_kt * fleet_kt));
  s.lattice.dk_npm = options_.lattice_fraction * width_k;
  s.lattice.dkt_npm = options_.lattice_fraction * width_kt;
  // The posterior predictive of (k, k_t), widened.
  model::TruckTableOptions::Population pop;
  const Eigen::ArrayXd K = theta_.row(kK).transpose().array(), Kt = theta_.row(kKt).transpose().array();
  const Eigen::ArrayXd sk = theta_.row(kSigmaK).transpose().array(), skt = theta_.row(kSigmaKt).transpose().array();
  pop.k_mean_npm = (W * K).sum();
  pop.kt_mean_npm = (W * Kt).sum();
  pop.k_sd_npm = options_.population_widening * std::sqrt((W * (sk.square() + (K - pop.k_mean_npm).square())).sum());
  pop.kt_sd_npm =
      options_.population_widening * std::sqrt((W * (skt.square() + (Kt - pop.kt_mean_npm).square())).sum());
  s.population = pop;
  return s;
}

double MarginalTarget::max_piece_sd(const Eigen::ArrayXd& W) const {
  const double low_sigma_z = weighted_quantile(theta_.row(kSigmaZ), W, 0.1);
  return std::clamp(options_.lateral_piece_fraction * low_sigma_z, options_.min_piece_sd_m,
                    std::max(options_.min_piece_sd_m, options_.table.max_piece_sd_m));
}

model::TruckTableOptions MarginalTarget::table_options(const TableSettings& s) const {
  model::TruckTableOptions o = options_.table;
  o.sigma_ref = s.sigma_ref;
  o.population = s.population;
  // Start the best-fit search at the fleet's predictive mean once that is a guide (a broad
  // predictive, as for the first trucks, is not: the search then spreads its start).
  if (s.population && s.population->k_sd_npm < 0.3 * s.population->k_mean_npm &&
      s.population->kt_sd_npm < 0.3 * s.population->kt_mean_npm) {
    o.k_start_npm = s.population->k_mean_npm;
    o.kt_start_npm = s.population->kt_mean_npm;
    o.start_is_close = true;
  }
  return o;
}

std::int64_t MarginalTarget::freeze_span(std::int64_t n) const {
  return std::clamp<std::int64_t>(n / options_.freeze_divisor, 1, options_.freeze_max);
}

const model::TruckTableOptions& MarginalTarget::frozen_table_options(const Eigen::ArrayXd& W) {
  const std::int64_t n = trucks();
  if (frozen_ && n < frozen_until_) return *frozen_;
  // Only the population follows the cloud; lattice and σ_ref change by rebuilds alone, so that
  // every table in the store shares them.
  TableSettings now = settings_;
  now.population = ideal_settings(W).population;
  model::TruckTableOptions o = table_options(now);
  o.max_piece_sd_m = max_piece_sd(W);
  // The table measures its lateral approximation at the fleet's current (Z, σ_z) (a diagnostic:
  // the tables do not depend on it).
  o.lateral_check = model::TruckTableOptions::LateralReference{(W * theta_.row(kZ).transpose().array()).sum(),
                                                               (W * theta_.row(kSigmaZ).transpose().array()).sum()};
  frozen_ = o;
  frozen_until_ = n + freeze_span(n);
  ++freeze_id_;
  prebuilt_.clear();
  return *frozen_;
}

std::size_t MarginalTarget::prebuild_span() const {
  const std::int64_t n = trucks();
  if (n == 0) return 0;
  return static_cast<std::size_t>(frozen_ && n < frozen_until_ ? frozen_until_ - n : freeze_span(n));
}

std::size_t MarginalTarget::prebuild(const std::vector<UpcomingTruck>& upcoming, const Eigen::ArrayXd& W,
                                     const smc::ParallelFor& parallel) {
  if (mode_ != Mode::kIdle) throw std::logic_error("MarginalTarget::prebuild: finish_stage() was not called");
  const std::int64_t n = trucks();
  if (n == 0 || upcoming.empty()) return 0;
  const model::TruckTableOptions o = frozen_table_options(W);
  const auto count = static_cast<std::size_t>(std::min<std::int64_t>(frozen_until_ - n, static_cast<std::int64_t>(upcoming.size())));
  // Already built for these options: nothing to do (the cache holds the span from its start).
  if (!prebuilt_.empty() && prebuilt_.front().truck <= n && prebuilt_.back().truck >= n + static_cast<std::int64_t>(count) - 1)
    return 0;
  for (const auto& u : upcoming) {
    if (u.site >= sites_.size() || u.impact_factors == nullptr || u.impact_factors->size() != site_of(u.site).sensors()) {
      throw UsageError("MarginalTarget::prebuild: an upcoming truck has no impact factors for its site");
    }
  }
  std::vector<Prebuilt> built(count);
  // One truck per thread; each table is built serially, so its bits are those of add_truck's.
  parallel(static_cast<Eigen::Index>(count), [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const UpcomingTruck& u = upcoming[static_cast<std::size_t>(i)];
      Prebuilt& b = built[static_cast<std::size_t>(i)];
      b.truck = n + i;
      b.freeze_id = freeze_id_;
      b.site = u.site;
      b.fit = model::fit_truck(site_of(u.site), u.speed_mps, u.sprung_mass_kg, *u.impact_factors, o);
      b.table = model::build_truck_table(site_of(u.site), u.speed_mps, u.sprung_mass_kg, *u.impact_factors,
                                         settings_.lattice, o, b.fit);
    }
  });
  prebuilt_ = std::move(built);
  return count;
}

void MarginalTarget::add_truck(double speed_mps, double sprung_mass_kg, const Eigen::VectorXd& impact_factors,
                               const Eigen::ArrayXd& W, const smc::ParallelFor& parallel, std::uint32_t site_index) {
  if (mode_ != Mode::kIdle) throw std::logic_error("MarginalTarget::add_truck: finish_stage() was not called");
  check_truck(site_index, impact_factors);
  const site::Site& site = site_of(site_index);
  const util::ParallelRange range = [&parallel](Eigen::Index n, const util::RangeBody& body) { parallel(n, body); };
  model::TruckFit fit;
  model::TruckTable table;
  if (trucks() == 0) {
    // The first truck sets the lattice's origin and first spacing, and σ_ref (its own noise
    // estimate, inside the prior box); the rebuild rule corrects both as the posterior forms.
    model::TruckTableOptions o = table_options(settings_);
    o.population.reset();
    o.max_piece_sd_m = max_piece_sd(W);
    fit = model::fit_truck(site, speed_mps, sprung_mass_kg, impact_factors, o);
    settings_.sigma_ref = std::clamp(fit.sigma_hat, options_.prior.lo[kSigmaIf], options_.prior.hi[kSigmaIf]);
    settings_.lattice.k_origin_npm = fit.stiffness_npm;
    settings_.lattice.kt_origin_npm = fit.tyre_stiffness_npm;
    // Integrand width unknown yet: assume the fleet spread is about the likelihood's (width / √2).
    settings_.lattice.dk_npm = options_.lattice_fraction * fit.stiffness_sd_per_sigma * settings_.sigma_ref / std::sqrt(2.0);
    settings_.lattice.dkt_npm =
        options_.lattice_fraction * fit.tyre_stiffness_sd_per_sigma * settings_.sigma_ref / std::sqrt(2.0);
    marginal_ = make_marginal(settings_.lattice);
    o.sigma_ref = settings_.sigma_ref;
    table = model::build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, settings_.lattice, o, fit, range);
  } else {
    const model::TruckTableOptions& o = frozen_table_options(W);
    const std::int64_t n = trucks();
    const auto it = std::find_if(prebuilt_.begin(), prebuilt_.end(),
                                 [&](const Prebuilt& b) {
                                   return b.truck == n && b.freeze_id == freeze_id_ && b.site == site_index;
                                 });
    if (it != prebuilt_.end()) {
      fit = it->fit;
      table = std::move(it->table);
      ++prebuilt_used_;
    } else {
      fit = model::fit_truck(site, speed_mps, sprung_mass_kg, impact_factors, o);
      table = model::build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, settings_.lattice, o, fit, range);
    }
  }
  passes_ += table.passes;
  if (std::isfinite(table.lateral_error_nats)) {
    ++lateral_checked_;
    lateral_error_abs_sum_ += std::abs(table.lateral_error_nats);
  }
  store_.append(table, site_index);
  speed_mps_.push_back(speed_mps);
  sprung_mass_kg_.push_back(sprung_mass_kg);
  observed_if_.push_back(impact_factors);
  fits_.push_back(fit);
  add_to_width_sums(fit);
  mode_ = Mode::kTruck;
}

std::string MarginalTarget::rebuild_reason(const Eigen::ArrayXd& W) const {
  const Eigen::Index n = trucks();
  if (n < 2 || mode_ != Mode::kIdle) return "";
  if (static_cast<double>(n) < options_.rebuild_growth * static_cast<double>(trucks_at_last_rebuild_)) return "";
  const TableSettings ideal = ideal_settings(W);
  std::ostringstream why;
  const double dlog_sigma = std::abs(std::log(ideal.sigma_ref / settings_.sigma_ref));
  if (dlog_sigma > options_.sigma_ref_tolerance) {
    why << "posterior sigma_if " << ideal.sigma_ref << " is far from the tables' " << settings_.sigma_ref;
  } else if (settings_.lattice.dk_npm > options_.too_coarse * ideal.lattice.dk_npm ||
             settings_.lattice.dk_npm < options_.too_fine * ideal.lattice.dk_npm ||
             settings_.lattice.dkt_npm > options_.too_coarse * ideal.lattice.dkt_npm ||
             settings_.lattice.dkt_npm < options_.too_fine * ideal.lattice.dkt_npm) {
    why << "lattice spacing (" << settings_.lattice.dk_npm << ", " << settings_.lattice.dkt_npm << ") N/m; ideal ("
        << ideal.lattice.dk_npm << ", " << ideal.lattice.dkt_npm << ")";
  } else if (population_at_rebuild_) {
    const auto& a = *population_at_rebuild_;
    const auto& b = *ideal.population;
    // The predictive has moved or widened beyond what the kept nodes were chosen for.
    if (std::abs(b.k_mean_npm - a.k_mean_npm) > 0.5 * a.k_sd_npm ||
        std::abs(b.kt_mean_npm - a.kt_mean_npm) > 0.5 * a.kt_sd_npm || b.k_sd_npm > 1.25 * a.k_sd_npm ||
        b.kt_sd_npm > 1.25 * a.kt_sd_npm) {
      why << "the fleet's predictive (k, k_t) moved from the one the tables kept their nodes for";
    }
  }
  return why.str();
}

void MarginalTarget::begin_rebuild(const Eigen::ArrayXd& W, const smc::ParallelFor& parallel) {
  if (mode_ != Mode::kIdle) throw std::logic_error("MarginalTarget::begin_rebuild: finish_stage() was not called");
  const TableSettings ideal = ideal_settings(W);
  model::TruckTableOptions o = table_options(ideal);
  o.max_piece_sd_m = max_piece_sd(W);
  const Eigen::Index n = trucks();
  std::vector<model::TruckTable> tables(static_cast<std::size_t>(n));
  parallel(n, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const auto u = static_cast<std::size_t>(i);
      tables[u] = model::build_truck_table(site_of(truck_sites()[u]), speed_mps_[u], sprung_mass_kg_[u],
                                           observed_if_[u], ideal.lattice, o, fits_[u]);
    }
  });
  model::TableStore fresh;
  std::size_t nodes = 0;
  for (const auto& t : tables) nodes += t.nodes();
  fresh.reserve(tables.size(), nodes);
  for (std::size_t u = 0; u < tables.size(); ++u) {
    const model::TruckTable& t = tables[u];
    fresh.append(t, truck_sites()[u]);
    passes_ += t.passes - t.fit.passes;
  }
  old_store_ = std::move(store_);
  old_marginal_ = marginal_;
  store_ = std::move(fresh);
  settings_ = ideal;
  marginal_ = make_marginal(settings_.lattice);
  trucks_at_last_rebuild_ = n;
  population_at_rebuild_ = ideal.population;
  ++rebuilds_;
  // New trucks' options follow the new settings from the next truck on.
  frozen_.reset();
  prebuilt_.clear();
  mode_ = Mode::kCorrection;
}

void MarginalTarget::finish_stage() {
  base_sum_ += inc_;
  inc_.setZero();
  mode_ = Mode::kIdle;
  old_store_.reset();
  old_marginal_.reset();
}

void MarginalTarget::log_density(Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                                 const smc::ParallelFor& parallel) {
  const std::size_t n = store_.trucks();
  parallel(options_.particles, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index p = begin; p < end; ++p) {
      const HyperVector th = theta_of(p);
      const double lp = options_.prior.log_prior(th) + log_jacobian(th);
      switch (mode_) {
        case Mode::kIdle:
          inc_[p] = 0.0;
          break;
        case Mode::kTruck:
          inc_[p] = marginal_.log_likelihood(store_.view(n - 1), marginal_.prepare(th));
          break;
        case Mode::kCorrection:
          inc_[p] = sum_loglik(store_, marginal_, n, th) - base_sum_[p];
          break;
      }
      log_base[p] = lp + base_sum_[p];
      loglik[p] = inc_[p];
    }
  });
}

void MarginalTarget::get_block(int /*block*/, Eigen::Ref<Eigen::MatrixXd> values) const {
  for (int j = 0; j < kHyperCount; ++j) {
    if (kLogScale[j])
      values.row(j) = theta_.row(j).array().log().matrix();
    else
      values.row(j) = theta_.row(j);
  }
}

void MarginalTarget::log_density_at(int /*block*/, const Eigen::Ref<const Eigen::MatrixXd>& proposed,
                                    Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                                    const smc::ParallelFor& parallel) {
  const std::size_t n = store_.trucks();
  parallel(options_.particles, [&](Eigen::Index begin, Eigen::Index end) {
    // The chunk's particles together: the sums over the stored trucks visit the store in
    // cache-sized blocks for all of them (FleetMarginal::sum_log_likelihood), with the same bits
    // as a sum per particle.
    const auto count = static_cast<std::size_t>(end - begin);
    std::vector<double> lp(count);
    std::vector<model::ThetaTerms> terms(count), old_terms;
    std::vector<double> base(count, kNegInf), sums(count);
    for (std::size_t c = 0; c < count; ++c) {
      const HyperVector th = from_move_coordinates(proposed, begin + static_cast<Eigen::Index>(c));
      lp[c] = options_.prior.log_prior(th);
      if (lp[c] > kNegInf) {
        lp[c] += log_jacobian(th);
        terms[c] = marginal_.prepare(th);  // default terms are outside the support: sum -inf
      }
    }
    std::vector<double> inc(count, 0.0);
    switch (mode_) {
      case Mode::kIdle:
        marginal_.sum_log_likelihood(store_, n, terms.data(), count, base.data());
        break;
      case Mode::kTruck:
        marginal_.sum_log_likelihood(store_, n - 1, terms.data(), count, base.data());
        for (std::size_t c = 0; c < count; ++c)
          if (lp[c] > kNegInf) inc[c] = marginal_.log_likelihood(store_.view(n - 1), terms[c]);
        break;
      case Mode::kCorrection:
        old_terms.resize(count);
        for (std::size_t c = 0; c < count; ++c)
          if (lp[c] > kNegInf)
            old_terms[c] = old_marginal_->prepare(from_move_coordinates(proposed, begin + static_cast<Eigen::Index>(c)));
        old_marginal_->sum_log_likelihood(*old_store_, n, old_terms.data(), count, base.data());
        marginal_.sum_log_likelihood(store_, n, terms.data(), count, sums.data());
        for (std::size_t c = 0; c < count; ++c) inc[c] = sums[c] - base[c];
        break;
    }
    for (std::size_t c = 0; c < count; ++c) {
      const Eigen::Index p = begin + static_cast<Eigen::Index>(c);
      double b = lp[c] > kNegInf ? base[c] : kNegInf, i = lp[c] > kNegInf ? inc[c] : 0.0;
      if (!(b > kNegInf) || std::isnan(i)) {
        b = kNegInf;
        i = 0.0;
      }
      proposed_base_sum_[p] = b;
      proposed_inc_[p] = i;
      log_base[p] = b == kNegInf ? kNegInf : lp[c] + b;
      loglik[p] = i;
    }
  });
}

void MarginalTarget::accept(int /*block*/, const std::vector<char>& accepted,
                            const Eigen::Ref<const Eigen::MatrixXd>& proposed) {
  for (Eigen::Index p = 0; p < options_.particles; ++p) {
    if (!accepted[static_cast<std::size_t>(p)]) continue;
    const HyperVector th = from_move_coordinates(proposed, p);
    for (int j = 0; j < kHyperCount; ++j) theta_(j, p) = th[static_cast<std::size_t>(j)];
    base_sum_[p] = proposed_base_sum_[p];
    inc_[p] = proposed_inc_[p];
  }
}

void MarginalTarget::resample(const std::vector<Eigen::Index>& ancestors) {
  const Eigen::MatrixXd theta = theta_;
  const Eigen::ArrayXd base = base_sum_, inc = inc_;
  for (Eigen::Index p = 0; p < options_.particles; ++p) {
    const Eigen::Index a = ancestors[static_cast<std::size_t>(p)];
    theta_.col(p) = theta.col(a);
    base_sum_[p] = base[a];
    inc_[p] = inc[a];
  }
}

}  // namespace ssrfleet::fleet
