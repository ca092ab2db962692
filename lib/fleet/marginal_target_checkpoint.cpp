// MarginalTarget's checkpoint (marginal_target.hpp, "Checkpoint"): the particles and settings in
// one fixed-size part, each truck's data, fit and table in an append-only part.
#include "fleet/marginal_target.hpp"

#include <string>
#include <type_traits>

#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr std::uint64_t kMagic = 0x4e52414d46525353ULL;  // "SSRFMARN"
// Version 2 adds the frozen options of new trucks' tables. A version-1 state (no frozen options) is
// read as one whose options are due to freeze at its next truck: exact, as every table in it is.
// Version 3 starts each truck record with its site's index (several sites, one fleet); a truck of
// an older state is of the only site there was, index 0.
// Version 4 adds the model fitted (an extension's name, "" for the base model) and each particle's
// ψ; an older state is of the base model.
// Version 5 adds each table entry's z-moment slopes in u (model/truck_table.hpp). A table of an older
// state has none: it is read with slopes of 0, its moments fixed as it was built and evaluated (the
// likelihood the build that wrote it evaluated), until the next rebuild gives every table its slopes.
// Version 6 adds the ψ window of an effect carried by one (its [lo, hi] and node count, after the
// settings) and, for such an effect, the window's Q tables in each truck record instead of one. A
// state without a window writes exactly version 5's records, so a base-model or second_class
// state of version 1-5 resumes as before; an effect carried by a window has no older state.
constexpr std::uint32_t kVersion = 6;

// One table: its node count, u_ref and the nine fields.
void write_table(BinaryWriter& out, const model::TableView& v) {
  out.value<std::uint32_t>(static_cast<std::uint32_t>(v.nodes));
  out.value(v.u_ref);
  auto write = [&](const auto* p) {
    for (std::size_t g = 0; g < v.nodes; ++g) out.value(p[g]);
  };
  write(v.k_index);
  write(v.kt_index);
  write(v.c);
  write(v.m);
  write(v.b);
  write(v.z_mean_m);
  write(v.z_var_m2);
  write(v.z_mean_slope_m);
  write(v.z_var_slope_m2);
}

model::TruckTable read_table(BinaryReader& in, std::uint32_t version) {
  model::TruckTable t;
  const auto nodes = in.value<std::uint32_t>("table nodes");
  if (nodes > 1'000'000) in.fail("table nodes", "implausible node count " + std::to_string(nodes));
  t.u_ref = in.value<double>("table u_ref");
  auto read = [&](auto& v, const char* what) {
    v.resize(nodes);
    for (auto& x : v) x = in.value<std::remove_reference_t<decltype(x)>>(what);
  };
  read(t.k_index, "table k index");
  read(t.kt_index, "table kt index");
  read(t.c, "table c");
  read(t.m, "table m");
  read(t.b, "table b");
  read(t.z_mean_m, "table z mean");
  read(t.z_var_m2, "table z var");
  if (version >= 5) {
    read(t.z_mean_slope_m, "table z mean slope");
    read(t.z_var_slope_m2, "table z var slope");
  }
  if (!(t.u_ref > 0.0)) in.fail("truck", "a truck record holds impossible values");
  return t;
}

}  // namespace

void MarginalTarget::save(BinaryWriter& out) const {
  save_particles(out);
  save_trucks(out, 0, static_cast<std::size_t>(trucks()));
}

void MarginalTarget::save_particles(BinaryWriter& out) const {
  if (mode_ != Mode::kIdle) throw std::logic_error("MarginalTarget::save: mid-stage");
  out.value(kMagic);
  out.value(kVersion);
  out.value(settings_.lattice);
  out.value(settings_.sigma_ref);
  out.value<std::uint8_t>(settings_.population ? 1 : 0);
  if (settings_.population) out.value(*settings_.population);
  out.value<std::uint8_t>(population_at_rebuild_ ? 1 : 0);
  if (population_at_rebuild_) out.value(*population_at_rebuild_);
  out.value<std::int64_t>(trucks_at_last_rebuild_);
  out.value<std::int32_t>(rebuilds_);
  // Every rank's passes (each counts its own tables'): the same count as one process's. Collective;
  // an exact sum adds whole numbers below 2^50 exactly.
  util::ExactSum passes;
  passes.add(static_cast<double>(passes_));
  ranks_->sum(&passes, 1);
  out.value<std::int64_t>(static_cast<std::int64_t>(passes.value()));
  out.value<std::uint8_t>(frozen_ ? 1 : 0);
  if (frozen_) {
    // What frozen_table_options() took from the cloud; the rest is options_.table.
    const model::TruckTableOptions& f = *frozen_;
    out.value(f.sigma_ref);
    out.value(f.k_start_npm);
    out.value(f.kt_start_npm);
    out.value<std::uint8_t>(f.start_is_close ? 1 : 0);
    out.value<std::uint8_t>(f.population ? 1 : 0);
    if (f.population) out.value(*f.population);
    out.value(f.max_piece_sd_m);
    out.value<std::uint8_t>(f.lateral_check ? 1 : 0);
    if (f.lateral_check) out.value(*f.lateral_check);
    out.value<std::int64_t>(frozen_until_);
  }
  out.matrix(theta_);
  out.matrix(base_sum_.matrix());
  out.text(options_.extension != nullptr ? options_.extension->name() : std::string());
  out.matrix(psi_);
  out.value<std::uint64_t>(absorbed_.size());
  // Last, so that the parts before are version 5's.
  out.value<std::uint8_t>(settings_.window ? 1 : 0);
  if (settings_.window) {
    out.value(settings_.window->lo);
    out.value(settings_.window->hi);
    out.value<std::int32_t>(settings_.window_nodes);
  }
}

// A truck's fit is written as its bytes: it must have no padding, whose bytes are indeterminate.
static_assert(sizeof(model::TruckFit) == 8 * sizeof(double) + 2 * sizeof(std::int32_t),
              "TruckFit has padding: a truck log would hold indeterminate bytes");

void MarginalTarget::save_trucks(BinaryWriter& out, std::size_t begin, std::size_t end) const {
  for (std::size_t i = begin; i < end; ++i) {
    // A truck's record holds its table, which only its own rank keeps (MarginalSmc gathers them).
    if (!ranks_->owns(i)) throw std::logic_error("MarginalTarget::save_trucks: truck " + std::to_string(i) + " is another rank's");
    out.value<std::uint32_t>(absorbed_.site(i));
    out.value(absorbed_.speed_mps(i));
    out.value(absorbed_.sprung_mass_kg(i));
    out.matrix(absorbed_.impact_factors(i));
    out.value(absorbed_.fit(i));
    for (const model::TableStore& store : stores_) write_table(out, store.view(i / static_cast<std::size_t>(ranks_->size())));
  }
}

std::uint64_t MarginalTarget::load_particles(BinaryReader& in) {
  if (in.value<std::uint64_t>("marginal target") != kMagic) in.fail("marginal target", "not a marginal-core state");
  const auto version = in.value<std::uint32_t>("marginal target version");
  if (version < 1 || version > kVersion) {
    in.fail("marginal target version", "format version " + std::to_string(version) + ", this build reads " +
                                           std::to_string(kVersion));
  }
  settings_.lattice = in.value<model::Lattice>("lattice");
  if (!settings_.lattice.valid() && settings_.lattice.dk_npm != 0.0) in.fail("lattice", "non-positive spacing");
  settings_.sigma_ref = in.value<double>("sigma_ref");
  settings_.population.reset();
  if (in.value<std::uint8_t>("population")) settings_.population = in.value<model::TruckTableOptions::Population>("population");
  population_at_rebuild_.reset();
  if (in.value<std::uint8_t>("population at rebuild"))
    population_at_rebuild_ = in.value<model::TruckTableOptions::Population>("population at rebuild");
  trucks_at_last_rebuild_ = in.value<std::int64_t>("trucks at last rebuild");
  rebuilds_ = in.value<std::int32_t>("rebuilds");
  // Rebuilds are spaced geometrically in n (at most ~50 below 1e8 trucks); a count outside this
  // range is damage (and would overflow the migrated generation, marginal_smc.hpp).
  if (rebuilds_ < 0 || rebuilds_ > 1'000'000) in.fail("rebuilds", "implausible rebuild count " + std::to_string(rebuilds_));
  passes_ = in.value<std::int64_t>("passes");
  if (ranks_->rank() != 0) passes_ = 0;  // the count so far stays with rank 0 (save_particles adds the ranks')
  frozen_.reset();
  frozen_until_ = 0;
  prebuilt_.clear();
  if (version >= 2 && in.value<std::uint8_t>("frozen table options")) {
    model::TruckTableOptions f = options_.table;
    f.sigma_ref = in.value<double>("frozen sigma_ref");
    f.k_start_npm = in.value<double>("frozen k start");
    f.kt_start_npm = in.value<double>("frozen kt start");
    f.start_is_close = in.value<std::uint8_t>("frozen start is close") != 0;
    if (in.value<std::uint8_t>("frozen population"))
      f.population = in.value<model::TruckTableOptions::Population>("frozen population");
    f.max_piece_sd_m = in.value<double>("frozen piece sd");
    if (in.value<std::uint8_t>("frozen lateral check"))
      f.lateral_check = in.value<model::TruckTableOptions::LateralReference>("frozen lateral check");
    frozen_until_ = in.value<std::int64_t>("frozen until");
    if (!(f.sigma_ref > 0.0) || !(f.max_piece_sd_m > 0.0) || frozen_until_ < 0) {
      in.fail("frozen table options", "impossible values");
    }
    frozen_ = f;
  }
  theta_ = in.matrix("theta", kHyperCount, options_.particles);
  base_sum_ = in.matrix("log-likelihood sums", options_.particles, 1).array();
  const std::string model = version >= 4 ? in.text("model", 4096) : std::string();
  const std::string wanted = options_.extension != nullptr ? options_.extension->name() : std::string();
  if (model != wanted) {
    in.fail("model", "the state fits model '" + (model.empty() ? std::string("base") : model) + "'; this run asks for '" +
                         (wanted.empty() ? std::string("base") : wanted) + "'");
  }
  if (version >= 4) psi_ = in.matrix("psi", psi_dim(), options_.particles);
  inc_ = Eigen::ArrayXd::Zero(options_.particles);
  const auto n = in.value<std::uint64_t>("trucks");
  if (n > 100'000'000ULL) in.fail("trucks", "implausible truck count " + std::to_string(n));
  const bool carried = carried_by_psi_window(options_.extension);
  if (carried && version < 6) {
    in.fail("psi window", "format version " + std::to_string(version) + " holds no psi window, which '" +
                              options_.extension->name() + "' on the marginal core needs (this build writes version " +
                              std::to_string(kVersion) + ")");
  }
  const bool has_window = version >= 6 && in.value<std::uint8_t>("psi window") != 0;
  if (has_window != carried) in.fail("psi window", has_window ? "a window this run's model has no use for" : "no window");
  if (has_window) {
    const auto lo = in.value<double>("psi window lo");
    const auto hi = in.value<double>("psi window hi");
    const auto q = in.value<std::int32_t>("psi window nodes");
    if (!(lo >= box_lo() && hi <= box_hi() && lo < hi) || q < 2 || q > kMaxPsiNodes)
      in.fail("psi window", "impossible window or node count");
    settings_.window = model::PsiWindow{lo, hi};
    settings_.window_nodes = q;  // as saved (the rule that chose it may differ)
    grid_.emplace(psi_window_grid(*settings_.window, q, box_lo(), box_hi()));
  }
  if (frozen_ && (frozen_until_ < static_cast<std::int64_t>(n) ||
                  frozen_until_ > static_cast<std::int64_t>(n) + options_.freeze_max)) {
    in.fail("frozen until", "truck " + std::to_string(frozen_until_) + " is not within a span of truck " +
                                std::to_string(n));
  }
  sum_log_sd_k_ = sum_log_sd_kt_ = 0.0;
  // Nothing is sized by n: it is not checked (its seal comes after the truck records), and up to 1e8
  // it would reserve 2 GB for a state of a few bytes. The store grows as records are read.
  stores_ = empty_stores();
  absorbed_ = AbsorbedTrucks(options_.table_spill_directory);
  marginal_ = make_marginal(settings_.lattice);
  loaded_version_ = version;
  mode_ = Mode::kIdle;
  old_stores_.reset();
  old_grid_.reset();
  old_marginal_.reset();
  k_lo_ = 0;
  k_hi_ = -1;
  return n;
}

void MarginalTarget::load_trucks(BinaryReader& in, std::uint64_t count) {
  for (std::uint64_t i = 0; i < count; ++i) {
    const std::uint32_t site = loaded_version_ >= 3 ? in.value<std::uint32_t>("truck site") : 0;
    if (site >= sites_.size()) {
      in.fail("truck site", "site " + std::to_string(site) + " of a state with " + std::to_string(sites_.size()) +
                                " site(s)");
    }
    const std::uint64_t truck = absorbed_.size();
    const auto speed = in.value<double>("truck speed");
    const auto mass = in.value<double>("truck mass");
    const Eigen::VectorXd impact_factors = in.matrix("impact factors", site_of(site).sensors(), 1);
    const auto fit = in.value<model::TruckFit>("truck fit");
    if (!std::isfinite(speed) || !std::isfinite(mass)) in.fail("truck", "a truck record holds impossible values");
    for (model::TableStore& store : stores_) {
      const model::TruckTable t = read_table(in, loaded_version_);
      note_k_range(t, k_lo_, k_hi_);
      if (ranks_->owns(truck)) store.append(t, site);  // another rank's table is read past
    }
    absorbed_.push_back(speed, mass, site, impact_factors, fit);
    add_to_width_sums(fit);
  }
}

void MarginalTarget::load(BinaryReader& in) {
  const std::uint64_t n = load_particles(in);
  load_trucks(in, n);
}

}  // namespace ssrfleet::fleet
