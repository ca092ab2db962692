#include "fleet/marginal_target.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <type_traits>

#include "model/truncated_samplers.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {

// Adds the wall time of its scope to a counter (MarginalTarget::table_seconds).
class ScopeTimer {
 public:
  explicit ScopeTimer(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  ~ScopeTimer() { total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  ScopeTimer(const ScopeTimer&) = delete;
  ScopeTimer& operator=(const ScopeTimer&) = delete;

 private:
  double& total_;
  std::chrono::steady_clock::time_point start_;
};

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// A table's nodes and u_ref as bytes, for the ranks that did not build it (the table's other
// fields are its builder's diagnostics).
std::string table_bytes(const model::TruckTable& t) {
  std::ostringstream os;
  BinaryWriter w(os);
  w.value<std::uint64_t>(t.nodes());
  w.value(t.u_ref);
  auto put = [&](const auto& v) {
    for (const auto& x : v) w.value(x);
  };
  put(t.k_index);
  put(t.kt_index);
  put(t.c);
  put(t.m);
  put(t.b);
  put(t.z_mean_m);
  put(t.z_var_m2);
  put(t.z_mean_slope_m);
  put(t.z_var_slope_m2);
  return os.str();
}

void read_table_bytes(const std::string& bytes, model::TruckTable& t) {
  std::istringstream is(bytes);
  BinaryReader r(is, "the newest truck's table");
  const auto nodes = r.value<std::uint64_t>("nodes");
  t.u_ref = r.value<double>("u_ref");
  auto get = [&](auto& v) {
    v.resize(nodes);
    for (auto& x : v) x = r.template value<std::remove_reference_t<decltype(x)>>("node");
  };
  get(t.k_index);
  get(t.kt_index);
  get(t.c);
  get(t.m);
  get(t.b);
  get(t.z_mean_m);
  get(t.z_var_m2);
  get(t.z_mean_slope_m);
  get(t.z_var_slope_m2);
}

// The moves' coordinates: the four scale parameters on the log scale, where the early posterior's
// funnels (a fleet sd near zero against a broad one) become walkable and a random walk scaled on
// the cloud's covariance fits the shape. Uniform priors on σ give a density σ on log σ.
constexpr bool kLogScale[kHyperCount] = {false, true, false, true, false, true, true};

// A particle's coordinates: θ, then the extension's ψ (up to this many parameters).
constexpr int kMaxPsi = 16;

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
    : sites_(std::move(sites)),
      options_(std::move(options)),
      ranks_(options_.ranks != nullptr ? options_.ranks : &util::single_rank()),
      marginal_(model::FleetMarginal(0, {}, {})),
      store_(options_.table_spill_directory),
      absorbed_(options_.table_spill_directory) {
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
  if (options_.extension != nullptr) {
    if (options_.extension->edits_forward()) {
      throw UsageError("the marginal core's tables hold the base model's forward model; '" + options_.extension->name() +
                       "' changes it (fit it with --core latent)");
    }
    if (options_.extension->dim() > kMaxPsi) throw UsageError("MarginalTarget: an extension with too many parameters");
  }
  theta_.resize(kHyperCount, options_.particles);
  psi_.resize(options_.extension != nullptr ? options_.extension->dim() : 0, options_.particles);
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
    // ψ from its uniform prior, after θ from the same stream (no draws without an extension).
    for (Eigen::Index j = 0; j < psi_dim(); ++j) {
      const ExtensionParameter& par = options_.extension->parameters()[static_cast<std::size_t>(j)];
      psi_(j, i) = par.lo + (par.hi - par.lo) * smc::uniform01(rng);
    }
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

void MarginalTarget::encode(const HyperVector& theta, const double* psi, double* x) const {
  for (int j = 0; j < kHyperCount; ++j) {
    const double v = theta[static_cast<std::size_t>(j)];
    x[j] = kLogScale[j] ? std::log(v) : v;
  }
  if (psi_dim() > 0) options_.extension->to_move_coordinates(psi, x + kHyperCount);
}

void MarginalTarget::decode(const double* x, HyperVector& theta, double* psi) const {
  for (int j = 0; j < kHyperCount; ++j) theta[static_cast<std::size_t>(j)] = kLogScale[j] ? std::exp(x[j]) : x[j];
  if (psi_dim() > 0) options_.extension->from_move_coordinates(x + kHyperCount, psi);
}

double MarginalTarget::log_jacobian(const HyperVector& theta, const double* psi) const {
  double s = 0.0;
  for (int j = 0; j < kHyperCount; ++j)
    if (kLogScale[j]) s += std::log(theta[static_cast<std::size_t>(j)]);
  if (psi_dim() > 0) s += options_.extension->log_move_jacobian(psi);
  return s;
}

double MarginalTarget::log_prior_of(const HyperVector& theta, const double* psi) const {
  double lp = options_.prior.log_prior(theta);
  if (psi_dim() > 0 && lp > kNegInf) lp += options_.extension->log_prior(psi);
  return lp;
}

void MarginalTarget::note_k_range(const model::TruckTable& table, int& lo, int& hi) const {
  for (const std::int32_t i : table.k_index) {
    if (hi < lo) {
      lo = hi = i;
    } else {
      lo = std::min(lo, static_cast<int>(i));
      hi = std::max(hi, static_cast<int>(i));
    }
  }
}

model::ThetaTerms MarginalTarget::terms_for(const model::FleetMarginal& marginal, const HyperVector& theta,
                                            const double* psi) const {
  if (psi == nullptr || psi_dim() == 0 || !options_.extension->edits_stiffness_distribution()) return marginal.prepare(theta);
  const bool old = old_marginal_ && &marginal == &*old_marginal_;
  return marginal.prepare(theta, options_.extension->stiffness_mixture(psi, theta[kK], theta[kSigmaK]),
                          old ? old_k_lo_ : k_lo_, old ? old_k_hi_ : k_hi_);
}

double MarginalTarget::sum_loglik(const model::TableStore& store, const model::FleetMarginal& marginal,
                                  const HyperVector& theta, const double* psi) const {
  const model::ThetaTerms terms = terms_for(marginal, theta, psi);
  util::ExactSum s;
  marginal.add_log_likelihoods(store, store.trucks(), &terms, 1, &s);
  ranks_->sum(&s, 1);
  return s.value();
}

double MarginalTarget::log_posterior(const HyperVector& theta, const double* psi) const {
  const double lp = log_prior_of(theta, psi);
  if (lp == kNegInf) return lp;
  return lp + sum_loglik(store_, marginal_, theta, psi);
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
  // FleetMarginal's floor (0.8 spacings) sits under the posterior's lower tail (Options); never
  // below a fraction of the median, so a broad early posterior does not make the lattice explode.
  // The quantile is that of a lognormal fitted to the cloud (the weighted mean and sd of log σ): the
  // empirical 0.1 % quantile of about a thousand particles is the lowest one or two, whose noise
  // made the lattice finer than needed and rebuilt it more often.
  const double z_q = truncated_normal_quantile(options_.lattice_sd_quantile, 0.0, 1.0, kNegInf, -kNegInf);
  auto resolved_sd = [&](const Eigen::RowVectorXd& sd) {
    const double median = weighted_quantile(sd, W, 0.5);
    const Eigen::ArrayXd log_sd = sd.transpose().array().log();
    const double m = (W * log_sd).sum(), v = (W * (log_sd - m).square()).sum();
    return std::max(std::exp(m + z_q * std::sqrt(v)), options_.lattice_sd_min_of_median * median);
  };
  const StiffnessMoments stiffness = stiffness_moments();
  const double fleet_k = resolved_sd(stiffness.narrowest_sd);
  const double fleet_kt = resolved_sd(theta_.row(kSigmaKt));
  const double width_k = 1.0 / std::sqrt(1.0 / (lik_k * lik_k) + 1.0 / (fleet_k * fleet_k));
  const double width_kt = 1.0 / std::sqrt(1.0 / (lik_kt * lik_kt) + 1.0 / (fleet_kt * fleet_kt));
  s.lattice.dk_npm = options_.lattice_fraction * width_k;
  s.lattice.dkt_npm = options_.lattice_fraction * width_kt;
  // The posterior predictive of (k, k_t), widened.
  model::TruckTableOptions::Population pop;
  const Eigen::ArrayXd K = stiffness.mean, Kt = theta_.row(kKt).transpose().array();
  const Eigen::ArrayXd sk = stiffness.sd, skt = theta_.row(kSigmaKt).transpose().array();
  pop.k_mean_npm = (W * K).sum();
  pop.kt_mean_npm = (W * Kt).sum();
  pop.k_sd_npm = options_.population_widening * std::sqrt((W * (sk.square() + (K - pop.k_mean_npm).square())).sum());
  pop.kt_sd_npm =
      options_.population_widening * std::sqrt((W * (skt.square() + (Kt - pop.kt_mean_npm).square())).sum());
  s.population = pop;
  return s;
}

MarginalTarget::StiffnessMoments MarginalTarget::stiffness_moments() const {
  StiffnessMoments m;
  const Eigen::Index P = options_.particles;
  m.mean = theta_.row(kK).transpose().array();
  m.sd = theta_.row(kSigmaK).transpose().array();
  m.narrowest_sd = theta_.row(kSigmaK);
  if (psi_dim() == 0 || !options_.extension->edits_stiffness_distribution()) return m;
  for (Eigen::Index p = 0; p < P; ++p) {
    const auto mixture = options_.extension->stiffness_mixture(psi_of(p), theta_(kK, p), theta_(kSigmaK, p));
    double mean = 0.0, second = 0.0, narrowest = theta_(kSigmaK, p);
    for (const auto& c : mixture) {
      mean += c.weight * c.mean_npm;
      second += c.weight * (c.sd_npm * c.sd_npm + c.mean_npm * c.mean_npm);
      if (c.weight >= kResolvedComponentWeight) narrowest = std::min(narrowest, c.sd_npm);
    }
    m.mean[p] = mean;
    m.sd[p] = std::sqrt(std::max(0.0, second - mean * mean));
    m.narrowest_sd[p] = narrowest;
  }
  return m;
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
  if (!prebuilt_.empty() && prebuilt_from_ <= n && prebuilt_until_ >= n + static_cast<std::int64_t>(count)) return 0;
  for (const auto& u : upcoming) {
    if (u.site >= sites_.size() || u.impact_factors == nullptr || u.impact_factors->size() != site_of(u.site).sensors()) {
      throw UsageError("MarginalTarget::prebuild: an upcoming truck has no impact factors for its site");
    }
  }
  // This rank's trucks of the span; the others' ranks build theirs at the same time.
  std::vector<std::size_t> mine;
  for (std::size_t i = 0; i < count; ++i)
    if (ranks_->owns(static_cast<std::uint64_t>(n) + i)) mine.push_back(i);
  std::vector<Prebuilt> built(mine.size());
  const ScopeTimer timer(table_seconds_);
  // One truck per thread; each table is built serially, so its bits are those of add_truck's.
  parallel(static_cast<Eigen::Index>(mine.size()), [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index k = begin; k < end; ++k) {
      const std::size_t i = mine[static_cast<std::size_t>(k)];
      const UpcomingTruck& u = upcoming[i];
      Prebuilt& b = built[static_cast<std::size_t>(k)];
      b.truck = n + static_cast<std::int64_t>(i);
      b.freeze_id = freeze_id_;
      b.site = u.site;
      b.fit = model::fit_truck(site_of(u.site), u.speed_mps, u.sprung_mass_kg, *u.impact_factors, o);
      b.table = model::build_truck_table(site_of(u.site), u.speed_mps, u.sprung_mass_kg, *u.impact_factors,
                                         settings_.lattice, o, b.fit);
    }
  });
  prebuilt_ = std::move(built);
  prebuilt_from_ = n;
  prebuilt_until_ = n + static_cast<std::int64_t>(count);
  return mine.size();
}

void MarginalTarget::add_truck(double speed_mps, double sprung_mass_kg, const Eigen::VectorXd& impact_factors,
                               const Eigen::ArrayXd& W, const smc::ParallelFor& parallel, std::uint32_t site_index) {
  if (mode_ != Mode::kIdle) throw std::logic_error("MarginalTarget::add_truck: finish_stage() was not called");
  check_truck(site_index, impact_factors);
  const site::Site& site = site_of(site_index);
  const util::ParallelRange range = [&parallel](Eigen::Index n, const util::RangeBody& body) { parallel(n, body); };
  const std::int64_t n = trucks();
  const bool mine = ranks_->owns(static_cast<std::uint64_t>(n));
  model::TruckFit fit;
  model::TruckTable table;
  std::optional<ScopeTimer> timer(std::in_place, table_seconds_);
  if (n == 0) {
    // The first truck sets the lattice's origin and first spacing, and σ_ref (its own noise
    // estimate, inside the prior box); the rebuild rule corrects both as the posterior forms.
    // Every rank builds it: the settings it sets are everyone's.
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
    if (mine) {
      const auto it = std::find_if(prebuilt_.begin(), prebuilt_.end(), [&](const Prebuilt& b) {
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
    timer.reset();  // the wait for the fit's rank below is not this rank's table work
    // Every rank keeps every truck's fit (the lattice follows their widths: ideal_settings) and its
    // table's lateral check (so the warning it feeds is the same on every rank).
    struct FromOwner {
      model::TruckFit fit;
      double lateral_error_nats;
    } shared{fit, table.lateral_error_nats};
    static_assert(std::is_trivially_copyable_v<FromOwner> && sizeof(FromOwner) == sizeof(model::TruckFit) + sizeof(double));
    const int owner = ranks_->owner(static_cast<std::uint64_t>(n));
    ranks_->broadcast(&shared, sizeof shared, owner);
    fit = shared.fit;
    table.lateral_error_nats = shared.lateral_error_nats;
    // Its table too, for the truck stage's slices of particles (one process: nothing to send).
    if (ranks_->size() > 1) {
      std::string bytes = mine ? table_bytes(table) : std::string();
      std::uint64_t size = bytes.size();
      ranks_->broadcast(&size, sizeof size, owner);
      bytes.resize(size);
      ranks_->broadcast(bytes.data(), bytes.size(), owner);
      if (!mine) read_table_bytes(bytes, table);
    }
  }
  newest_ = model::TableStore{};
  newest_.append(table, site_index);
  note_k_range(table, k_lo_, k_hi_);
  if (std::isfinite(table.lateral_error_nats)) {
    ++lateral_checked_;
    lateral_error_abs_sum_ += std::abs(table.lateral_error_nats);
  }
  if (mine) {
    passes_ += table.passes;
    store_.append(table, site_index);
  }
  absorbed_.push_back(speed_mps, sprung_mass_kg, site_index, impact_factors, fit);
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
  // This rank's trucks: the k-th of its store is truck rank + k × size.
  const auto local = static_cast<Eigen::Index>(store_.trucks());
  const auto global = [&](Eigen::Index k) {
    return static_cast<std::size_t>(ranks_->rank()) + static_cast<std::size_t>(k) * static_cast<std::size_t>(ranks_->size());
  };
  const ScopeTimer timer(table_seconds_);
  // Built in batches, each appended to the new store before the next is built, so a rebuild holds
  // at most a batch of tables besides the stores (a spilled store keeps memory flat through it).
  model::TableStore fresh(store_.spill_directory());
  int fresh_lo = 0, fresh_hi = -1;
  std::vector<model::TruckTable> tables;
  for (Eigen::Index from = 0; from < local; from += kRebuildBatch) {
    const Eigen::Index batch = std::min(kRebuildBatch, local - from);
    tables.assign(static_cast<std::size_t>(batch), model::TruckTable{});
    parallel(batch, [&](Eigen::Index begin, Eigen::Index end) {
      for (Eigen::Index k = begin; k < end; ++k) {
        const std::size_t u = global(from + k);
        tables[static_cast<std::size_t>(k)] =
            model::build_truck_table(site_of(absorbed_.site(u)), absorbed_.speed_mps(u), absorbed_.sprung_mass_kg(u),
                                     absorbed_.impact_factors(u), ideal.lattice, o, absorbed_.fit(u));
      }
    });
    for (Eigen::Index k = 0; k < batch; ++k) {
      const model::TruckTable& t = tables[static_cast<std::size_t>(k)];
      fresh.append(t, absorbed_.site(global(from + k)));
      note_k_range(t, fresh_lo, fresh_hi);
      passes_ += t.passes - t.fit.passes;
    }
  }
  old_store_ = std::move(store_);
  old_marginal_ = marginal_;
  old_k_lo_ = k_lo_;
  old_k_hi_ = k_hi_;
  k_lo_ = fresh_lo;
  k_hi_ = fresh_hi;
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
  const Eigen::Index P = options_.particles;
  // Each rank computes the newest truck's ℓ for its slice of the particles (truck stage), or sums
  // its own trucks (correction); then the ranks exchange (outside the threads).
  // Plain names, not a structured binding: clang 14 (the fuzz build's) cannot capture one.
  const std::pair<std::size_t, std::size_t> slice = ranks_->slice(static_cast<std::size_t>(P));
  const std::size_t slice_begin = slice.first, slice_end = slice.second;
  std::vector<util::ExactSum> sums(mode_ == Mode::kCorrection ? static_cast<std::size_t>(P) : 0);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index p = begin; p < end; ++p) {
      const HyperVector th = theta_of(p);
      const double* psi = psi_of(p);
      const auto u = static_cast<std::size_t>(p);
      switch (mode_) {
        case Mode::kIdle:
          inc_[p] = 0.0;
          break;
        case Mode::kTruck:
          inc_[p] = u >= slice_begin && u < slice_end ? marginal_.log_likelihood(newest_.view(0), terms_for(marginal_, th, psi))
                                                      : 0.0;
          break;
        case Mode::kCorrection: {
          const model::ThetaTerms terms = terms_for(marginal_, th, psi);
          marginal_.add_log_likelihoods(store_, store_.trucks(), &terms, 1, &sums[static_cast<std::size_t>(p)]);
          break;
        }
      }
    }
  });
  if (mode_ == Mode::kTruck) ranks_->share_slices(inc_.data(), static_cast<std::size_t>(P));
  if (mode_ == Mode::kCorrection) {
    ranks_->sum(sums.data(), sums.size());
    for (Eigen::Index p = 0; p < P; ++p) inc_[p] = sums[static_cast<std::size_t>(p)].value() - base_sum_[p];
  }
  for (Eigen::Index p = 0; p < P; ++p) {
    const HyperVector th = theta_of(p);
    log_base[p] = log_prior_of(th, psi_of(p)) + log_jacobian(th, psi_of(p)) + base_sum_[p];
    loglik[p] = inc_[p];
  }
}

void MarginalTarget::get_block(int /*block*/, Eigen::Ref<Eigen::MatrixXd> values) const {
  for (int j = 0; j < kHyperCount; ++j) {
    if (kLogScale[j])
      values.row(j) = theta_.row(j).array().log().matrix();
    else
      values.row(j) = theta_.row(j);
  }
  std::array<double, kMaxPsi> u{};
  for (Eigen::Index p = 0; p < psi_.cols() && psi_dim() > 0; ++p) {
    options_.extension->to_move_coordinates(psi_.col(p).data(), u.data());
    for (Eigen::Index j = 0; j < psi_dim(); ++j) values(kHyperCount + j, p) = u[static_cast<std::size_t>(j)];
  }
}

void MarginalTarget::log_density_at(int /*block*/, const Eigen::Ref<const Eigen::MatrixXd>& proposed,
                                    Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                                    const smc::ParallelFor& parallel) {
  const Eigen::Index P = options_.particles;
  const auto count = static_cast<std::size_t>(P);
  const std::size_t n = absorbed_.size();
  const std::size_t local = store_.trucks();
  const bool newest_mine = n > 0 && ranks_->owns(n - 1);
  const std::pair<std::size_t, std::size_t> slice = ranks_->slice(count);
  const std::size_t slice_begin = slice.first, slice_end = slice.second;
  // Per particle: the log prior (with the Jacobian), the exact sum over this rank's trucks in log γ
  // (the old tables' in a correction), the new tables' sum (correction) and the newest truck's ℓ
  // (truck stage, this rank's slice of the particles). The exchange follows, outside the threads.
  std::vector<double> lp(count), inc(count, 0.0);
  std::vector<util::ExactSum> sums(mode_ == Mode::kCorrection ? 2 * count : count);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    // The chunk's particles together: the sums over the stored trucks visit the store in
    // cache-sized blocks for all of them (FleetMarginal::add_log_likelihoods).
    const auto chunk = static_cast<std::size_t>(end - begin);
    const auto first = static_cast<std::size_t>(begin);
    std::vector<model::ThetaTerms> terms(chunk), old_terms;
    std::vector<HyperVector> thetas(chunk);
    std::vector<double> psis(chunk * static_cast<std::size_t>(psi_dim()));
    auto psi_at = [&](std::size_t c) { return psi_dim() > 0 ? psis.data() + c * static_cast<std::size_t>(psi_dim()) : nullptr; };
    for (std::size_t c = 0; c < chunk; ++c) {
      decode(proposed.col(begin + static_cast<Eigen::Index>(c)).data(), thetas[c], psi_at(c));
      lp[first + c] = log_prior_of(thetas[c], psi_at(c));
      if (lp[first + c] > kNegInf) {
        lp[first + c] += log_jacobian(thetas[c], psi_at(c));
        terms[c] = terms_for(marginal_, thetas[c], psi_at(c));  // default terms are outside the support: sum -inf
      }
    }
    util::ExactSum* base = sums.data() + first;
    switch (mode_) {
      case Mode::kIdle:
        marginal_.add_log_likelihoods(store_, local, terms.data(), chunk, base);
        break;
      case Mode::kTruck:
        marginal_.add_log_likelihoods(store_, newest_mine ? local - 1 : local, terms.data(), chunk, base);
        for (std::size_t c = 0; c < chunk; ++c) {
          const std::size_t p = first + c;
          if (p >= slice_begin && p < slice_end && lp[p] > kNegInf) inc[p] = marginal_.log_likelihood(newest_.view(0), terms[c]);
        }
        break;
      case Mode::kCorrection:
        old_terms.resize(chunk);
        for (std::size_t c = 0; c < chunk; ++c)
          if (lp[first + c] > kNegInf)
            old_terms[c] = terms_for(*old_marginal_, thetas[c], psi_at(c));
        old_marginal_->add_log_likelihoods(*old_store_, old_store_->trucks(), old_terms.data(), chunk, base);
        marginal_.add_log_likelihoods(store_, local, terms.data(), chunk, sums.data() + count + first);
        break;
    }
  });
  ranks_->sum(sums.data(), sums.size());
  if (mode_ == Mode::kTruck) ranks_->share_slices(inc.data(), count);
  for (std::size_t c = 0; c < count; ++c) {
    const double base = sums[c].value();
    if (mode_ == Mode::kCorrection) inc[c] = sums[count + c].value() - base;
    const auto p = static_cast<Eigen::Index>(c);
    double b = lp[c] > kNegInf ? base : kNegInf, i = lp[c] > kNegInf ? inc[c] : 0.0;
    if (!(b > kNegInf) || std::isnan(i)) {
      b = kNegInf;
      i = 0.0;
    }
    proposed_base_sum_[p] = b;
    proposed_inc_[p] = i;
    log_base[p] = b == kNegInf ? kNegInf : lp[c] + b;
    loglik[p] = i;
  }
}

void MarginalTarget::accept(int /*block*/, const std::vector<char>& accepted,
                            const Eigen::Ref<const Eigen::MatrixXd>& proposed) {
  for (Eigen::Index p = 0; p < options_.particles; ++p) {
    if (!accepted[static_cast<std::size_t>(p)]) continue;
    HyperVector th;
    decode(proposed.col(p).data(), th, psi_dim() > 0 ? psi_.col(p).data() : nullptr);
    for (int j = 0; j < kHyperCount; ++j) theta_(j, p) = th[static_cast<std::size_t>(j)];
    base_sum_[p] = proposed_base_sum_[p];
    inc_[p] = proposed_inc_[p];
  }
}

void MarginalTarget::resample(const std::vector<Eigen::Index>& ancestors) {
  const Eigen::MatrixXd theta = theta_, psi = psi_;
  const Eigen::ArrayXd base = base_sum_, inc = inc_;
  for (Eigen::Index p = 0; p < options_.particles; ++p) {
    const Eigen::Index a = ancestors[static_cast<std::size_t>(p)];
    theta_.col(p) = theta.col(a);
    if (psi_dim() > 0) psi_.col(p) = psi.col(a);
    base_sum_[p] = base[a];
    inc_[p] = inc[a];
  }
}

}  // namespace ssrfleet::fleet
