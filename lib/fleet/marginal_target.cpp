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

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

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
    if (options_.extension->edits_forward() && !carried_by_psi_window(options_.extension)) {
      throw UsageError("the marginal core carries the base model, a stiffness mixture (second_class) and one-parameter "
                       "effects inside the dynamics; '" + options_.extension->name() +
                       "' is none of these (fit it with --core latent)");
    }
    if (options_.extension->dim() > kMaxPsi) throw UsageError("MarginalTarget: an extension with too many parameters");
  }
  const auto& rule = options_.psi_window.rule;
  if (rule.nodes < 2 || rule.nodes > kMaxPsiNodes || options_.psi_window.box_nodes < 2 ||
      options_.psi_window.box_nodes > kMaxPsiNodes) {
    throw UsageError("MarginalTarget: a psi window needs 2 to " + std::to_string(kMaxPsiNodes) + " nodes");
  }
  if (!(rule.inner_sd > 0.0 && rule.inner_sd < rule.half_width_sd && rule.too_wide > 0.0 && rule.too_wide < 1.0)) {
    throw UsageError("MarginalTarget: psi window rule needs 0 < inner_sd < half_width_sd and too_wide in (0, 1)");
  }
  // Before the first truck the window is the prior box: the posterior is the prior.
  if (carried_by_psi_window(options_.extension))
    set_window(model::PsiWindow{box_lo(), box_hi()});
  else
    stores_ = empty_stores();
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

void MarginalTarget::add_node_sums(const std::vector<model::TableStore>& stores, const model::FleetMarginal& marginal,
                                   std::size_t end, const model::ThetaTerms* terms, std::size_t count,
                                   util::ExactSum* out, std::size_t stride) {
  for (std::size_t q = 0; q < stores.size(); ++q) marginal.add_log_likelihoods(stores[q], end, terms, count, out + q * stride);
}

double MarginalTarget::sum_loglik(const std::vector<model::TableStore>& stores, const model::PsiGrid* grid,
                                  const model::FleetMarginal& marginal, const HyperVector& theta, const double* psi) const {
  const model::ThetaTerms terms = terms_for(marginal, theta, psi);
  std::vector<util::ExactSum> s(stores.size());
  add_node_sums(stores, marginal, stores.front().trucks(), &terms, 1, s.data(), 1);
  ranks_->sum(s.data(), s.size());
  return combine(grid, psi, s.data(), 1);
}

double MarginalTarget::log_posterior(const HyperVector& theta, const double* psi) const {
  const double lp = log_prior_of(theta, psi);
  if (lp == kNegInf) return lp;
  return lp + sum_loglik(stores_, psi_grid(), marginal_, theta, psi);
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
  // The ψ window round the posterior (the prior box while the posterior is as broad).
  if (grid_) {
    const PsiMoments m = psi_moments(psi_, W, box_lo(), box_hi());
    s.window = model::psi_window(options_.psi_window.rule, m.mean, m.sd, box_lo(), box_hi());
    s.window_nodes = psi_window_nodes(options_.psi_window, *s.window, box_lo(), box_hi());
  }
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

void MarginalTarget::finish_stage() {
  base_sum_ += inc_;
  inc_.setZero();
  mode_ = Mode::kIdle;
  old_stores_.reset();
  old_grid_.reset();
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
  const auto count = static_cast<std::size_t>(P);
  const std::size_t nodes = stores_.size();
  // Node-major: node q's sum for particle p at sums[q * P + p] (one node without a window).
  std::vector<util::ExactSum> sums(mode_ == Mode::kCorrection ? nodes * count : 0);
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
          inc_[p] = u >= slice_begin && u < slice_end ? newest_loglik(terms_for(marginal_, th, psi), psi) : 0.0;
          break;
        case Mode::kCorrection: {
          const model::ThetaTerms terms = terms_for(marginal_, th, psi);
          add_node_sums(stores_, marginal_, stores_.front().trucks(), &terms, 1, &sums[u], count);
          break;
        }
      }
    }
  });
  if (mode_ == Mode::kTruck) ranks_->share_slices(inc_.data(), static_cast<std::size_t>(P));
  if (mode_ == Mode::kCorrection) {
    ranks_->sum(sums.data(), sums.size());
    for (Eigen::Index p = 0; p < P; ++p)
      inc_[p] = combine(psi_grid(), psi_of(p), &sums[static_cast<std::size_t>(p)], count) - base_sum_[p];
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
  const std::size_t local = stores_.front().trucks();
  const std::size_t nodes = stores_.size(), old_nodes = old_stores_ ? old_stores_->size() : 0;
  const bool newest_mine = n > 0 && ranks_->owns(n - 1);
  const std::pair<std::size_t, std::size_t> slice = ranks_->slice(count);
  const std::size_t slice_begin = slice.first, slice_end = slice.second;
  // Per particle: the log prior (with the Jacobian), the exact sum over this rank's trucks in log γ
  // (the old tables' in a correction), the new tables' sum (correction) and the newest truck's ℓ
  // (truck stage, this rank's slice of the particles). The exchange follows, outside the threads.
  std::vector<double> lp(count), inc(count, 0.0);
  std::vector<double> proposed_psi(count * static_cast<std::size_t>(psi_dim()));
  // Node-major: the base sum's node q for particle c at sums[q * count + c] (the old tables' in a
  // correction), then the new tables' nodes after them (correction).
  const std::size_t base_nodes = mode_ == Mode::kCorrection ? old_nodes : nodes;
  std::vector<util::ExactSum> sums((base_nodes + (mode_ == Mode::kCorrection ? nodes : 0)) * count);
  parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
    // The chunk's particles together: the sums over the stored trucks visit the store in
    // cache-sized blocks for all of them (FleetMarginal::add_log_likelihoods).
    const auto chunk = static_cast<std::size_t>(end - begin);
    const auto first = static_cast<std::size_t>(begin);
    std::vector<model::ThetaTerms> terms(chunk), old_terms;
    std::vector<HyperVector> thetas(chunk);
    auto psi_at = [&](std::size_t c) {
      return psi_dim() > 0 ? proposed_psi.data() + (first + c) * static_cast<std::size_t>(psi_dim()) : nullptr;
    };
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
        add_node_sums(stores_, marginal_, local, terms.data(), chunk, base, count);
        break;
      case Mode::kTruck:
        add_node_sums(stores_, marginal_, newest_mine ? local - 1 : local, terms.data(), chunk, base, count);
        for (std::size_t c = 0; c < chunk; ++c) {
          const std::size_t p = first + c;
          if (p >= slice_begin && p < slice_end && lp[p] > kNegInf) inc[p] = newest_loglik(terms[c], psi_at(c));
        }
        break;
      case Mode::kCorrection:
        old_terms.resize(chunk);
        for (std::size_t c = 0; c < chunk; ++c)
          if (lp[first + c] > kNegInf)
            old_terms[c] = terms_for(*old_marginal_, thetas[c], psi_at(c));
        add_node_sums(*old_stores_, *old_marginal_, old_stores_->front().trucks(), old_terms.data(), chunk, base, count);
        add_node_sums(stores_, marginal_, local, terms.data(), chunk, sums.data() + old_nodes * count + first, count);
        break;
    }
  });
  ranks_->sum(sums.data(), sums.size());
  if (mode_ == Mode::kTruck) ranks_->share_slices(inc.data(), count);
  const model::PsiGrid* base_grid = mode_ == Mode::kCorrection ? (old_grid_ ? &*old_grid_ : nullptr) : psi_grid();
  for (std::size_t c = 0; c < count; ++c) {
    const auto p = static_cast<Eigen::Index>(c);
    // Outside the prior's support no sum is read (the proposal's ψ may be outside the box too).
    const double* psi = psi_dim() > 0 ? proposed_psi.data() + c * static_cast<std::size_t>(psi_dim()) : nullptr;
    const double base = lp[c] > kNegInf ? combine(base_grid, psi, &sums[c], count) : kNegInf;
    if (mode_ == Mode::kCorrection && lp[c] > kNegInf)
      inc[c] = combine(psi_grid(), psi, &sums[old_nodes * count + c], count) - base;
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
