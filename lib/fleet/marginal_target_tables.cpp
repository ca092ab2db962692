// MarginalTarget's tables (marginal_target.hpp): building a new truck's (at every node of the ψ window
// when an effect rides in one), prebuilding the next ones, and the rebuilds that follow the posterior.
#include "fleet/marginal_target.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <type_traits>

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

}  // namespace

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

std::vector<model::TableStore> MarginalTarget::empty_stores() const {
  std::vector<model::TableStore> stores;
  const std::size_t nodes = grid_ ? static_cast<std::size_t>(grid_->size()) : 1;
  for (std::size_t q = 0; q < nodes; ++q) stores.emplace_back(options_.table_spill_directory);
  return stores;
}

void MarginalTarget::set_window(const model::PsiWindow& window) {
  settings_.window = window;
  settings_.window_nodes = psi_window_nodes(options_.psi_window, window, box_lo(), box_hi());
  grid_.emplace(psi_window_grid(window, settings_.window_nodes, box_lo(), box_hi()));
  stores_ = empty_stores();
}

std::vector<model::TruckTable> MarginalTarget::build_tables(std::uint32_t site, double speed_mps, double sprung_mass_kg,
                                                            const Eigen::VectorXd& impact_factors,
                                                            const TableSettings& settings,
                                                            const model::TruckTableOptions& options,
                                                            model::TruckFit& fit, bool fit_given) const {
  const site::Site& s = site_of(site);
  if (!settings.window) {
    if (!fit_given) fit = model::fit_truck(s, speed_mps, sprung_mass_kg, impact_factors, options);
    return {model::build_truck_table(s, speed_mps, sprung_mass_kg, impact_factors, settings.lattice, options, fit)};
  }
  // Each node's table under its own ψ, from its own fit (the best fit moves with ψ).
  const model::PsiGrid grid = psi_window_grid(*settings.window, settings.window_nodes, box_lo(), box_hi());
  std::vector<model::TruckTable> tables;
  tables.reserve(static_cast<std::size_t>(grid.size()));
  for (int q = 0; q < grid.size(); ++q) {
    model::TruckTableOptions o = options;
    o.forward = model::ForwardEdit{options_.extension, {grid.nodes()[static_cast<std::size_t>(q)]}};
    const model::TruckFit f = model::fit_truck(s, speed_mps, sprung_mass_kg, impact_factors, o);
    if (q == grid.size() / 2) fit = f;  // the middle node's (tables() views its store)
    tables.push_back(model::build_truck_table(s, speed_mps, sprung_mass_kg, impact_factors, settings.lattice, o, f));
  }
  return tables;
}

double MarginalTarget::newest_loglik(const model::ThetaTerms& terms, const double* psi) const {
  if (!grid_) return marginal_.log_likelihood(newest_[0].view(0), terms);
  std::array<double, kMaxPsiNodes> values{};
  for (std::size_t q = 0; q < newest_.size(); ++q) values[q] = marginal_.log_likelihood(newest_[q].view(0), terms);
  return interpolate_node_sums(*grid_, psi[0], values.data(), 1);
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
      b.tables = build_tables(u.site, u.speed_mps, u.sprung_mass_kg, *u.impact_factors, settings_, o, b.fit, false);
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
  const std::size_t nodes = stores_.size();
  model::TruckFit fit;
  std::vector<model::TruckTable> tables(nodes);
  // A truck's tables at a window's nodes: one per thread, each built serially (the same bits).
  auto build_windowed = [&](const model::TruckTableOptions& o) {
    const model::PsiGrid& grid = *grid_;
    std::vector<model::TruckFit> fits(nodes);
    parallel(static_cast<Eigen::Index>(nodes), [&](Eigen::Index begin, Eigen::Index end) {
      for (Eigen::Index q = begin; q < end; ++q) {
        model::TruckTableOptions oq = o;
        oq.forward = model::ForwardEdit{options_.extension, {grid.nodes()[static_cast<std::size_t>(q)]}};
        auto& f = fits[static_cast<std::size_t>(q)];
        f = model::fit_truck(site, speed_mps, sprung_mass_kg, impact_factors, oq);
        tables[static_cast<std::size_t>(q)] =
            model::build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, settings_.lattice, oq, f);
      }
    });
    fit = fits[nodes / 2];
  };
  std::optional<ScopeTimer> timer(std::in_place, table_seconds_);
  if (n == 0) {
    // The first truck sets the lattice's origin and first spacing, and σ_ref (its own noise
    // estimate, inside the prior box); the rebuild rule corrects both as the posterior forms.
    // Every rank builds it: the settings it sets are everyone's. With a ψ window, from the fit at
    // its middle node.
    model::TruckTableOptions o = table_options(settings_);
    o.population.reset();
    o.max_piece_sd_m = max_piece_sd(W);
    model::TruckTableOptions o_fit = o;
    if (grid_) o_fit.forward = model::ForwardEdit{options_.extension, {grid_->nodes()[nodes / 2]}};
    fit = model::fit_truck(site, speed_mps, sprung_mass_kg, impact_factors, o_fit);
    settings_.sigma_ref = std::clamp(fit.sigma_hat, options_.prior.lo[kSigmaIf], options_.prior.hi[kSigmaIf]);
    settings_.lattice.k_origin_npm = fit.stiffness_npm;
    settings_.lattice.kt_origin_npm = fit.tyre_stiffness_npm;
    // Integrand width unknown yet: assume the fleet spread is about the likelihood's (width / √2).
    settings_.lattice.dk_npm = options_.lattice_fraction * fit.stiffness_sd_per_sigma * settings_.sigma_ref / std::sqrt(2.0);
    settings_.lattice.dkt_npm =
        options_.lattice_fraction * fit.tyre_stiffness_sd_per_sigma * settings_.sigma_ref / std::sqrt(2.0);
    marginal_ = make_marginal(settings_.lattice);
    o.sigma_ref = settings_.sigma_ref;
    if (grid_)
      build_windowed(o);
    else
      tables[0] = model::build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, settings_.lattice, o, fit, range);
  } else {
    const model::TruckTableOptions& o = frozen_table_options(W);
    if (mine) {
      const auto it = std::find_if(prebuilt_.begin(), prebuilt_.end(), [&](const Prebuilt& b) {
        return b.truck == n && b.freeze_id == freeze_id_ && b.site == site_index;
      });
      if (it != prebuilt_.end()) {
        fit = it->fit;
        tables = std::move(it->tables);
        ++prebuilt_used_;
      } else if (grid_) {
        build_windowed(o);
      } else {
        fit = model::fit_truck(site, speed_mps, sprung_mass_kg, impact_factors, o);
        tables[0] = model::build_truck_table(site, speed_mps, sprung_mass_kg, impact_factors, settings_.lattice, o, fit, range);
      }
    }
    timer.reset();  // the wait for the fit's rank below is not this rank's table work
    // Every rank keeps every truck's fit (the lattice follows their widths: ideal_settings) and its
    // table's lateral check (so the warning it feeds is the same on every rank).
    const std::size_t mid = nodes / 2;
    struct FromOwner {
      model::TruckFit fit;
      double lateral_error_nats;
    } shared{fit, tables[mid].lateral_error_nats};
    static_assert(std::is_trivially_copyable_v<FromOwner> && sizeof(FromOwner) == sizeof(model::TruckFit) + sizeof(double));
    const int owner = ranks_->owner(static_cast<std::uint64_t>(n));
    ranks_->broadcast(&shared, sizeof shared, owner);
    fit = shared.fit;
    tables[mid].lateral_error_nats = shared.lateral_error_nats;
    // Its tables too, for the truck stage's slices of particles (one process: nothing to send).
    if (ranks_->size() > 1) {
      for (auto& table : tables) {
        std::string bytes = mine ? table_bytes(table) : std::string();
        std::uint64_t size = bytes.size();
        ranks_->broadcast(&size, sizeof size, owner);
        bytes.resize(size);
        ranks_->broadcast(bytes.data(), bytes.size(), owner);
        if (!mine) read_table_bytes(bytes, table);
      }
    }
  }
  newest_.clear();
  newest_.resize(nodes);
  for (std::size_t q = 0; q < nodes; ++q) {
    newest_[q].append(tables[q], site_index);
    note_k_range(tables[q], k_lo_, k_hi_);
  }
  // The lateral check of the middle node's table (the base model's without a window).
  const double lateral = tables[nodes / 2].lateral_error_nats;
  if (std::isfinite(lateral)) {
    ++lateral_checked_;
    lateral_error_abs_sum_ += std::abs(lateral);
  }
  if (mine) {
    for (std::size_t q = 0; q < nodes; ++q) {
      passes_ += tables[q].passes;
      stores_[q].append(tables[q], site_index);
    }
  }
  absorbed_.push_back(speed_mps, sprung_mass_kg, site_index, impact_factors, fit);
  add_to_width_sums(fit);
  mode_ = Mode::kTruck;
}

bool MarginalTarget::window_due(const Eigen::ArrayXd& W, std::string* why) const {
  if (!grid_) return false;
  const PsiMoments m = psi_moments(psi_, W, box_lo(), box_hi());
  const auto check = model::check_psi_window(options_.psi_window.rule, *settings_.window, m.mean, m.sd, box_lo(), box_hi());
  const double n = static_cast<double>(trucks()), last = static_cast<double>(trucks_at_last_rebuild_);
  std::ostringstream os;
  os << "psi window [" << settings_.window->lo << ", " << settings_.window->hi << "] ";
  // Narrowed: the current window is still right, only coarser than it could be: at the geometric
  // spacing of every rebuild. Moved: the posterior nears the window's end (mean ± inner_sd sd
  // leaves it), so sooner, but still spaced geometrically (psi_moved_growth), which bounds the
  // rebuilds' cost per truck by 1 / (psi_moved_growth - 1) tables per node amortised.
  if (check == model::PsiWindowCheck::kMoved && n >= options_.psi_moved_growth * last) {
    os << "moved: posterior " << m.mean << " +- " << m.sd;
  } else if (check == model::PsiWindowCheck::kNarrowed && n >= options_.rebuild_growth * last) {
    os << "narrowed: posterior " << m.mean << " +- " << m.sd;
  } else {
    return false;
  }
  if (why != nullptr) *why = os.str();
  return true;
}

std::string MarginalTarget::rebuild_reason(const Eigen::ArrayXd& W) const {
  const Eigen::Index n = trucks();
  if (n < 2 || mode_ != Mode::kIdle) return "";
  std::string window_why;
  if (window_due(W, &window_why)) return window_why;
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
  const auto local = static_cast<Eigen::Index>(stores_.front().trucks());
  const auto global = [&](Eigen::Index k) {
    return static_cast<std::size_t>(ranks_->rank()) + static_cast<std::size_t>(k) * static_cast<std::size_t>(ranks_->size());
  };
  const ScopeTimer timer(table_seconds_);
  // Built in batches, each appended to the new stores before the next is built, so a rebuild holds
  // at most a batch of tables besides the stores (a spilled store keeps memory flat through it).
  // Every rebuild puts the ψ window where the posterior now is (ideal_settings): all tables are
  // rebuilt anyway.
  const std::size_t nodes = ideal.window ? static_cast<std::size_t>(ideal.window_nodes) : 1;
  std::vector<model::TableStore> fresh;
  for (std::size_t q = 0; q < nodes; ++q) fresh.emplace_back(options_.table_spill_directory);
  int fresh_lo = 0, fresh_hi = -1;
  std::vector<std::vector<model::TruckTable>> tables;
  for (Eigen::Index from = 0; from < local; from += kRebuildBatch) {
    const Eigen::Index batch = std::min(kRebuildBatch, local - from);
    tables.assign(static_cast<std::size_t>(batch), {});
    parallel(batch, [&](Eigen::Index begin, Eigen::Index end) {
      for (Eigen::Index k = begin; k < end; ++k) {
        const std::size_t u = global(from + k);
        model::TruckFit fit = absorbed_.fit(u);
        tables[static_cast<std::size_t>(k)] = build_tables(absorbed_.site(u), absorbed_.speed_mps(u),
                                                           absorbed_.sprung_mass_kg(u), absorbed_.impact_factors(u),
                                                           ideal, o, fit, /*fit_given=*/true);
      }
    });
    for (Eigen::Index k = 0; k < batch; ++k) {
      for (std::size_t q = 0; q < nodes; ++q) {
        const model::TruckTable& t = tables[static_cast<std::size_t>(k)][q];
        fresh[q].append(t, absorbed_.site(global(from + k)));
        note_k_range(t, fresh_lo, fresh_hi);
        // Without a window the truck's fit was reused; with one each node's was made anew.
        passes_ += ideal.window ? t.passes : t.passes - t.fit.passes;
      }
    }
  }
  old_stores_ = std::move(stores_);
  old_grid_ = std::move(grid_);
  old_marginal_ = marginal_;
  old_k_lo_ = k_lo_;
  old_k_hi_ = k_hi_;
  k_lo_ = fresh_lo;
  k_hi_ = fresh_hi;
  stores_ = std::move(fresh);
  settings_ = ideal;
  grid_.reset();
  if (ideal.window) grid_.emplace(psi_window_grid(*ideal.window, ideal.window_nodes, box_lo(), box_hi()));
  marginal_ = make_marginal(settings_.lattice);
  trucks_at_last_rebuild_ = n;
  population_at_rebuild_ = ideal.population;
  ++rebuilds_;
  // New trucks' options follow the new settings from the next truck on.
  frozen_.reset();
  prebuilt_.clear();
  mode_ = Mode::kCorrection;
}

}  // namespace ssrfleet::fleet
