// How much the marginal core's table error varies across the posterior. The posterior moves with
// E(θ) = Σ_i (ℓ_i,table(θ) - ℓ_i,exact(θ)) only through how E varies over θ (a constant offset
// cancels), so this measures, on a simulated log fitted as `ssrfleet fit` fits it:
//   E(θ_d) = (n / m) Σ_{i in a random subset of m trucks} (ℓ_i,table(θ_d) - ℓ_i,exact(θ_d))
// at D posterior draws θ_d (the final cloud resampled by weight), its max - min over the draws,
// the mean shift it implies for each hyperparameter in posterior sd (Cov_d(θ_j, E) / sd_j: a tilt
// exp(E) moves a posterior mean by Cov(θ, E) to first order), and both split by error source:
//   rectangle   the rectangle rule on the table's lattice (fleet sds floored as FleetMarginal does),
//               z exact, against the exact reference (table_error_reference.hpp, a refined lattice)
//   dropping    the table's kept nodes only, against every node of its lattice (z exact)
//   laplace     the table's Laplace form in σ_IF (its c, m, b per node) with the exact lateral
//               ratio, against the exact z-integral at the kept nodes (also holds the table's
//               z-window: the reference integrates the whole road)
//   lateral     the table's moment matching of N(z | Z, σ_z²) (per node or piece, its z-moments
//               moved to the draw's σ_IF by the entry's slopes as FleetMarginal moves them), in double
//   float       the single-precision node sum of FleetMarginal against the same formula in double
// The components add up to the total. Rows after them try remedies on the same nodes: the rectangle
// rule without the floor or with cell masses below it, and the lateral form with each one-piece
// node's z-moments at the draw's σ_IF (exactly, or first order in u from u_ref as a table could
// store them from the reference's own derivatives, s² linear in u), or with the table's slopes
// but s² linear in u (the other form the slopes allow). Uncertainty from the truck subset: a
// bootstrap over trucks.
// Each configuration (a knob of MarginalTarget::Options) is a fit of its own (its cost: integrator
// passes, entries and table time per truck) evaluated at the default fit's draws and subset.
//
//   table_error_benchmark --case a|b|c --trucks 1000 --draws 50 --subset 30 --threads 2
//                         [--configs default,piece12,...] [--refine 2] [--check-trucks 3]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "fleet/marginal_smc.hpp"
#include "fleet_presets.hpp"
#include "model/fleet_model.hpp"
#include "run_info.hpp"
#include "site/road_source.hpp"
#include "smc_fit.hpp"
#include "table_error_reference.hpp"

using namespace ssrfleet;
using namespace ssrfleet::bench::table_error;

namespace {

using clock_type = std::chrono::steady_clock;

double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}

// Case (c): Table 1 with a narrower, more central lateral spread and a narrower stiffness spread,
// on the class C road.
bench::FleetPreset narrow_z_fleet() {
  fleet::FleetDistribution d;
  d.lateral_m = {1.2, 0.25};
  d.stiffness_npm = {500e3, 30e3};
  return {"narrow_z", "Table 1 with Z 1.2 sd 0.25, sigma_k 30k, on AS3", "AS3", d, 0.02};
}

bench::FleetPreset preset_for_case(const std::string& c) {
  if (c == "a") return bench::table1_fleet();
  if (c == "b") return bench::second_fleet();
  if (c == "c") return narrow_z_fleet();
  throw std::invalid_argument("--case must be a, b or c");
}

// The knobs, one named configuration each.
fleet::MarginalTarget::Options config_options(const std::string& name) {
  fleet::MarginalTarget::Options o;
  if (name == "default") return o;
  if (name == "piece12") {
    o.lateral_piece_fraction = 1.0 / 12.0;
    o.min_piece_sd_m = 0.01;
  } else if (name == "piece24") {
    o.lateral_piece_fraction = 1.0 / 24.0;
    o.min_piece_sd_m = 0.005;
  } else if (name == "lattice07") {
    o.lattice_fraction = 0.7;
  } else if (name == "keep16") {
    o.table.keep_nats = 16.0;
  } else if (name == "sigtol02") {
    o.sigma_ref_tolerance = 0.02;
  } else if (name == "sigtol01") {
    o.sigma_ref_tolerance = 0.01;
  } else if (name == "pts20") {
    o.table.points_per_segment = 20;
  } else {
    throw std::invalid_argument("unknown config " + name);
  }
  return o;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

// ℓ from node values Y_gd on a lattice: (M/2) log(u/2π) + log(Δk Δkt) + log Σ_g N N exp(Y_g).
struct NodeTerm {
  std::pair<int, int> ij;
  double y;
};
double assemble(const model::Lattice& lattice, const std::vector<NodeTerm>& terms, const Draw& d, int sensors,
                bool floor_sd) {
  double s = kNegInf;
  for (const NodeTerm& t : terms) s = log_add(s, TruckReference::log_prior(lattice, t.ij, d.theta, floor_sd) + t.y);
  return 0.5 * sensors * (d.log_u - fleet::kLog2Pi) + std::log(lattice.dk_npm * lattice.dkt_npm) + s;
}

// log of N(x | mean, sd²)'s mass on [x - h/2, x + h/2] per unit length.
double log_cell_density(double x, double h, double mean, double sd) {
  const double a = (x - 0.5 * h - mean) / (sd * std::numbers::sqrt2), b = (x + 0.5 * h - mean) / (sd * std::numbers::sqrt2);
  double mass;
  if (a > 0.0) mass = 0.5 * (std::erfc(a) - std::erfc(b));
  else if (b < 0.0) mass = 0.5 * (std::erfc(-b) - std::erfc(-a));
  else mass = 0.5 * (std::erf(b) - std::erf(a));
  if (mass > 0.0) return std::log(mass / h);
  return fleet::log_normal_density(x, mean, sd);  // far tail: the cell's mass underflows
}

// The same node sum where a fleet sd below FleetMarginal's floor is not floored: in that direction
// each node's prior weight is the fleet density's mass on the node's cell (exact where the
// likelihood is flat across a cell, as it is when the fleet sd, not the likelihood, is narrow);
// above the floor the point density, as now (the cell mass would err by ~ (spacing / width)² / 24).
double assemble_cells(const model::Lattice& lattice, const std::vector<NodeTerm>& terms, const Draw& d, int sensors) {
  const fleet::HyperVector& t = d.theta;
  double s = kNegInf;
  for (const NodeTerm& n : terms) {
    const double k = lattice.k_at(n.ij.first), kt = lattice.kt_at(n.ij.second);
    const double sk = t[fleet::kSigmaK], skt = t[fleet::kSigmaKt];
    const double floor = model::FleetMarginal::kMinSdPerSpacing;
    const double pk = sk < floor * lattice.dk_npm ? log_cell_density(k, lattice.dk_npm, t[fleet::kK], sk)
                                                  : fleet::log_normal_density(k, t[fleet::kK], sk);
    const double pkt = skt < floor * lattice.dkt_npm ? log_cell_density(kt, lattice.dkt_npm, t[fleet::kKt], skt)
                                                     : fleet::log_normal_density(kt, t[fleet::kKt], skt);
    s = log_add(s, pk + pkt + n.y);
  }
  return 0.5 * sensors * (d.log_u - fleet::kLog2Pi) + std::log(lattice.dk_npm * lattice.dkt_npm) + s;
}

enum Component {
  kTab,
  kDouble,
  kLaplaceOnly,
  kKeptExact,
  kLatticeExact,
  kExact,
  kLatticeUnfloored,
  kLatticeCells,
  kMomentsAtU,
  kMomentsFirstOrder,
  kSlopesLinearVar,
  kComponents
};
const char* kSourceNames[] = {"total",
                              "rectangle (+floor)",
                              "dropping",
                              "laplace+window",
                              "lateral",
                              "float",
                              "z-integral (laplace+window+lateral)",
                              "  rectangle, no floor",
                              "  rectangle, cell mass below the floor",
                              "  lateral, one-piece nodes' z-moments at the draw's u",
                              "  lateral, one-piece nodes' z-moments first order in u",
                              "  lateral, the table's slopes with s² linear in u"};
constexpr int kSources = 12;
// Source s of one truck at one draw, from its six likelihoods.
double source(const std::array<double, kComponents>& l, int s) {
  switch (s) {
    case 0: return l[kTab] - l[kExact];
    case 1: return l[kLatticeExact] - l[kExact];
    case 2: return l[kKeptExact] - l[kLatticeExact];
    case 3: return l[kLaplaceOnly] - l[kKeptExact];
    case 4: return l[kDouble] - l[kLaplaceOnly];
    case 5: return l[kTab] - l[kDouble];
    case 6: return l[kDouble] - l[kKeptExact];
    case 7: return l[kLatticeUnfloored] - l[kExact];
    case 8: return l[kLatticeCells] - l[kExact];
    // The lateral source with the table's lateral form replaced (kDouble -> the variant).
    case 9: return l[kMomentsAtU] - l[kLaplaceOnly];
    case 10: return l[kMomentsFirstOrder] - l[kLaplaceOnly];
    default: return l[kSlopesLinearVar] - l[kLaplaceOnly];
  }
}

struct FitCost {
  double wall_s = 0.0, table_s = 0.0, passes_per_truck = 0.0, entries_per_table = 0.0;
  int rebuilds = 0;
  double sigma_ref = 0.0;
  model::Lattice lattice;
};

struct Sample {
  std::vector<Draw> draws;           // D posterior draws, then the posterior mean
  fleet::HyperVector mean{}, sd{};   // of the cloud
};

Sample draw_from(const fleet::PosteriorCloud& cloud, int D, std::uint64_t seed, double lo, double hi) {
  Sample s;
  const Eigen::ArrayXd& W = cloud.weights;
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const Eigen::ArrayXd x = cloud.theta.row(h).transpose().array();
    const double m = (W * x).sum() / W.sum();
    s.mean[static_cast<std::size_t>(h)] = m;
    s.sd[static_cast<std::size_t>(h)] = std::sqrt((W * (x - m).square()).sum() / W.sum());
  }
  std::mt19937_64 rng(seed);
  std::discrete_distribution<Eigen::Index> pick(W.data(), W.data() + W.size());
  for (int d = 0; d < D; ++d) {
    const Eigen::Index p = pick(rng);
    fleet::HyperVector t;
    for (int h = 0; h < fleet::kHyperCount; ++h) t[static_cast<std::size_t>(h)] = cloud.theta(h, p);
    s.draws.push_back(make_draw(t, lo, hi));
  }
  s.draws.push_back(make_draw(s.mean, lo, hi));
  return s;
}

std::string fmt(double x, int digits = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, x);
  return buf;
}
std::string fmt_g(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  std::string case_name = "a", configs_arg = "default", dump_prefix;
  int trucks = 1000, D = 50, m = 30, threads = 2, refine = 2, check_trucks = 3, particles = 1024;
  std::uint64_t data_seed = 1, smc_seed = 11, pick_seed = 5;
  double threshold = 25.0;
  double sigma_if_override = 0.0, sigma_z_override = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--case") case_name = next();
    else if (a == "--trucks") trucks = std::stoi(next());
    else if (a == "--draws") D = std::stoi(next());
    else if (a == "--subset") m = std::stoi(next());
    else if (a == "--threads") threads = std::stoi(next());
    else if (a == "--refine") refine = std::stoi(next());
    else if (a == "--check-trucks") check_trucks = std::stoi(next());
    else if (a == "--particles") particles = std::stoi(next());
    else if (a == "--data-seed") data_seed = std::stoull(next());
    else if (a == "--smc-seed") smc_seed = std::stoull(next());
    else if (a == "--configs") configs_arg = next();
    else if (a == "--threshold") threshold = std::stod(next());
    else if (a == "--sigma-if") sigma_if_override = std::stod(next());
    else if (a == "--sigma-z") sigma_z_override = std::stod(next());
    else if (a == "--dump") dump_prefix = next();
    else {
      std::cerr << "usage: table_error_benchmark --case a|b|c [--trucks N] [--draws D] [--subset m] [--threads T]\n"
                   "  [--configs default,piece12,piece24,lattice07,keep16,sigtol02,sigtol01,pts20] [--refine r]\n"
                   "  [--check-trucks k] [--particles P] [--data-seed s] [--smc-seed s] [--threshold nats]\n"
                   "  [--sigma-if s] [--sigma-z s] [--dump prefix]\n";
      return 2;
    }
  }
  bench::FleetPreset preset = preset_for_case(case_name);
  // Variants of a case: more noise (broader z-likelihoods) or another lateral spread.
  if (sigma_if_override > 0.0) {
    preset.sigma_if = sigma_if_override;
    preset.description += ", sigma_IF " + fmt_g(sigma_if_override);
  }
  if (sigma_z_override > 0.0) {
    preset.distribution.lateral_m.sd = sigma_z_override;
    preset.description += ", sigma_z " + fmt_g(sigma_z_override);
  }
  const site::Site site(site::load_road(preset.road), site::SiteOptions{});
  const double lo = site.lateral_min_m(), hi = site.lateral_max_m();
  const fleet::SimulatedLog log = bench::simulate_preset(site, preset, trucks, data_seed);
  const int M = site.sensors();
  smc::ParallelFor pool(threads);
  const util::ParallelRange range = [&pool](Eigen::Index n, const util::RangeBody& body) { pool(n, body); };

  std::cout << "# table error, case " << case_name << ": " << preset.description << "\n\n"
            << "n = " << trucks << ", road " << preset.road << ", sigma_IF " << preset.sigma_if << ", data seed "
            << data_seed << ", SMC seed " << smc_seed << ", " << particles << " particles, " << threads
            << " threads; D = " << D << " draws, m = " << m << " trucks; reference lattice refined x" << refine
            << ", flood to " << threshold << " nats; load " << fmt(bench::load_average_1min(), 1) << ", "
            << bench::utc_now() << "\n\n";

  Sample sample;
  std::vector<std::size_t> subset;
  // Per subset truck, per draw: ℓ_exact.
  std::vector<std::vector<double>> exact;
  const double scale = static_cast<double>(trucks) / m;

  for (const std::string& config : split(configs_arg)) {
    fleet::MarginalSmc::Options o = bench::smc_options(smc_seed, threads);
    o.sampler.particles = particles;
    o.target = config_options(config);
    fleet::MarginalSmc smc(site, o);
    const auto t0 = clock_type::now();
    bench::replay_and_rejuvenate(smc, log.records, o.sampler.schedule.final_sweeps);
    FitCost cost;
    cost.wall_s = seconds_since(t0);
    const fleet::MarginalTarget& target = smc.target();
    cost.table_s = target.table_seconds();
    cost.passes_per_truck = static_cast<double>(target.integrator_passes()) / trucks;
    cost.entries_per_table = static_cast<double>(target.tables().nodes()) / trucks;
    cost.rebuilds = target.rebuilds();
    cost.sigma_ref = target.settings().sigma_ref;
    cost.lattice = target.marginal().lattice();
    std::cerr << config << ": fit " << fmt(cost.wall_s, 1) << " s, tables " << fmt(cost.table_s, 1) << " s, "
              << fmt(cost.passes_per_truck, 0) << " passes/truck, " << fmt(cost.entries_per_table, 1)
              << " entries/table, " << cost.rebuilds << " rebuilds\n";

    const model::FleetMarginal& marginal = target.marginal();
    const model::Lattice lattice = marginal.lattice();
    const bool first = exact.empty();
    if (first) {
      sample = draw_from(smc.cloud(), D, smc_seed + 1000, lo, hi);
      std::vector<std::size_t> all(static_cast<std::size_t>(trucks));
      std::iota(all.begin(), all.end(), std::size_t{0});
      std::mt19937_64 rng(pick_seed);
      std::shuffle(all.begin(), all.end(), rng);
      subset.assign(all.begin(), all.begin() + m);
      std::cout << "posterior (this fit): ";
      for (int h = 0; h < fleet::kHyperCount; ++h)
        std::cout << (h ? ", " : "") << fleet::kHyperNames[h] << " " << fmt_g(sample.mean[static_cast<std::size_t>(h)])
                  << " ± " << fmt_g(sample.sd[static_cast<std::size_t>(h)]);
      std::cout << "\ntruth: " << bench::truth_line(preset) << "\n\n";
    }
    const std::vector<Draw>& draws = sample.draws;
    const std::size_t DD = draws.size();  // D draws and the posterior mean

    // Six likelihoods per subset truck and draw.
    std::vector<std::vector<std::array<double, kComponents>>> l(subset.size(),
                                                                std::vector<std::array<double, kComponents>>(DD));
    long long ref_passes = 0;
    double check_max = 0.0, check_spread = 0.0;
    const auto t1 = clock_type::now();
    for (std::size_t s = 0; s < subset.size(); ++s) {
      const std::size_t i = subset[s];
      const records::WimRecord& r = log.records[i];
      const model::TableView view = target.tables().view(i);
      TruckReference ref(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, draws, range);
      // The table's entries by node.
      std::map<std::pair<int, int>, std::vector<std::size_t>> by_node;
      for (std::size_t g = 0; g < view.nodes; ++g) by_node[{view.k_index[g], view.kt_index[g]}].push_back(g);
      std::vector<std::pair<int, int>> kept;
      for (const auto& [ij, e] : by_node) kept.push_back(ij);
      // Every node of the table's lattice (the kept ones among them), z exact.
      const TruckReference::NodeMap on_lattice = ref.flood(lattice, kept, threshold, true, true, view.u_ref);
      if (first) {
        std::vector<std::pair<int, int>> seeds;
        for (const auto& ij : kept) seeds.emplace_back(refine * ij.first, refine * ij.second);
        model::Lattice fine = lattice;
        fine.dk_npm /= refine;
        fine.dkt_npm /= refine;
        const TruckReference::NodeMap on_fine = ref.flood(fine, seeds, threshold, false, false);
        std::vector<double> e(DD);
        for (std::size_t d = 0; d < DD; ++d) {
          std::vector<NodeTerm> terms;
          for (const auto& [ij, v] : on_fine) terms.push_back({ij, v.x[d]});
          e[d] = assemble(fine, terms, draws[d], M, false);
        }
        if (static_cast<int>(s) < check_trucks) {
          // The reference against a finer one.
          model::Lattice finer = lattice;
          finer.dk_npm /= refine + 1;
          finer.dkt_npm /= refine + 1;
          std::vector<std::pair<int, int>> seeds2;
          for (const auto& ij : kept) seeds2.emplace_back((refine + 1) * ij.first, (refine + 1) * ij.second);
          const TruckReference::NodeMap on_finer = ref.flood(finer, seeds2, threshold + 5.0, false, false);
          double lo_d = 1e300, hi_d = -1e300;
          for (std::size_t d = 0; d < DD; ++d) {
            std::vector<NodeTerm> terms;
            for (const auto& [ij, v] : on_finer) terms.push_back({ij, v.x[d]});
            const double diff = assemble(finer, terms, draws[d], M, false) - e[d];
            check_max = std::max(check_max, std::abs(diff));
            lo_d = std::min(lo_d, diff);
            hi_d = std::max(hi_d, diff);
          }
          check_spread = std::max(check_spread, hi_d - lo_d);
          if (s == 0) {
            // One node's z-integral against the library's brute-force reference.
            const auto& [ij, v] = *on_lattice.find(kept.front());
            const fleet::HyperVector& t = draws.back().theta;
            const double brute = model::reference_log_z_integral(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor,
                                                                  lattice.k_at(ij.first), lattice.kt_at(ij.second),
                                                                  t[fleet::kSigmaIf], t[fleet::kZ], t[fleet::kSigmaZ]);
            std::cout << "closed-form z-integral against model::reference_log_z_integral at one node: "
                      << fmt_g(v.x.back() - brute) << " nats\n";
          }
        }
        exact.push_back(std::move(e));
      }
      ref_passes += ref.passes();
      for (std::size_t d = 0; d < DD; ++d) {
        const Draw& dr = draws[d];
        const fleet::HyperVector& t = dr.theta;
        auto& out = l[s][d];
        out[kExact] = exact[s][d];
        out[kTab] = marginal.log_likelihood(view, marginal.prepare(t));
        const double sz2 = t[fleet::kSigmaZ] * t[fleet::kSigmaZ];
        std::vector<NodeTerm> dbl, lap, kept_exact, all_exact, at_u, first_order, linear_var;
        // The Gaussian lateral form, exactly (no expansion in ε).
        auto gaussian_lateral = [&](double z_mean, double z_var) {
          const double v = sz2 + z_var, dz = z_mean - t[fleet::kZ];
          return -0.5 * (fleet::kLog2Pi + std::log(v)) - dz * dz / (2.0 * v) - dr.log_mass;
        };
        for (const auto& [ij, entries] : by_node) {
          const auto& v = on_lattice.at(ij);
          double y_d = kNegInf, y_l = kNegInf, y_v = kNegInf;
          // The table's lateral form, expanded in ε as FleetMarginal expands it.
          auto table_lateral = [&](double z_mean, double z_var) {
            const double eps = z_var / sz2, dz = z_mean - t[fleet::kZ];
            return -0.5 * (fleet::kLog2Pi + std::log(sz2)) - dr.log_mass - 0.5 * eps -
                   dz * dz / (2.0 * sz2) * (1.0 - eps + eps * eps);
          };
          for (std::size_t g : entries) {
            const double laplace = view.c[g] - view.m[g] * 0.5 * dr.u - view.b[g] * dr.log_u;
            const model::FleetMarginal::EntryMoments z = model::FleetMarginal::entry_moments(view, g, dr.u);
            y_d = log_add(y_d, laplace + table_lateral(z.z_mean_m, z.z_var_m2));
            y_l = log_add(y_l, laplace);
            // The same slopes with s² linear in u instead of u s²: s² + x (v' - s²), kept >= 0.
            const double x = model::FleetMarginal::slope_step(view.u_ref, dr.u);
            const double var_linear =
                std::max(0.0, view.z_var_m2[g] + x * (static_cast<double>(view.z_var_slope_m2[g]) - view.z_var_m2[g]));
            y_v = log_add(y_v, laplace + table_lateral(z.z_mean_m, var_linear));
          }
          dbl.push_back({ij, y_d});
          linear_var.push_back({ij, y_v});
          if (entries.size() == 1) {
            const double du = dr.u - view.u_ref;
            at_u.push_back({ij, y_l + gaussian_lateral(v.z_mean[d], v.z_var[d])});
            first_order.push_back(
                {ij, y_l + gaussian_lateral(v.z_mean_ref + du * v.dz_mean_du, std::max(0.0, v.z_var_ref + du * v.dz_var_du))});
          } else {
            at_u.push_back({ij, y_d});
            first_order.push_back({ij, y_d});
          }
          lap.push_back({ij, y_l + v.x[d] - v.x0[d]});
          kept_exact.push_back({ij, v.x[d]});
        }
        for (const auto& [ij, v] : on_lattice) all_exact.push_back({ij, v.x[d]});
        out[kDouble] = assemble(lattice, dbl, dr, M, true);
        out[kLaplaceOnly] = assemble(lattice, lap, dr, M, true);
        out[kKeptExact] = assemble(lattice, kept_exact, dr, M, true);
        out[kLatticeExact] = assemble(lattice, all_exact, dr, M, true);
        out[kLatticeUnfloored] = assemble(lattice, all_exact, dr, M, false);
        out[kLatticeCells] = assemble_cells(lattice, all_exact, dr, M);
        out[kMomentsAtU] = assemble(lattice, at_u, dr, M, true);
        out[kMomentsFirstOrder] = assemble(lattice, first_order, dr, M, true);
        out[kSlopesLinearVar] = assemble(lattice, linear_var, dr, M, true);
      }
      std::cerr << "  truck " << i << ": " << view.nodes << " entries, " << by_node.size() << " nodes, " << on_lattice.size()
                << " lattice nodes; tab-exact at the mean " << fmt_g(l[s][DD - 1][kTab] - l[s][DD - 1][kExact]) << "\n";
    }
    const double ref_s = seconds_since(t1);
    if (!dump_prefix.empty()) {
      // Every truck's six likelihoods at every draw (the last draw is the posterior mean).
      std::ofstream dump(dump_prefix + "-" + config + ".csv");
      dump << "truck,draw";
      for (int h = 0; h < fleet::kHyperCount; ++h) dump << "," << fleet::kHyperNames[h];
      dump << ",tab,dbl,laplace_only,kept_exact,lattice_exact,exact,lattice_unfloored,lattice_cells,moments_at_u,"
              "moments_first_order,slopes_linear_var\n";
      dump.precision(17);
      for (std::size_t s = 0; s < subset.size(); ++s)
        for (std::size_t d = 0; d < DD; ++d) {
          dump << subset[s] << "," << d;
          for (int h = 0; h < fleet::kHyperCount; ++h) dump << "," << draws[d].theta[static_cast<std::size_t>(h)];
          for (int c = 0; c < kComponents; ++c) dump << "," << l[s][d][static_cast<std::size_t>(c)];
          dump << "\n";
        }
    }

    // Statistics over draws d < D.
    auto spread_of = [&](const std::vector<std::size_t>& trucks_used, int src, std::vector<double>* e_out) {
      std::vector<double> e(static_cast<std::size_t>(D), 0.0);
      for (std::size_t s : trucks_used)
        for (int d = 0; d < D; ++d) e[static_cast<std::size_t>(d)] += scale * source(l[s][static_cast<std::size_t>(d)], src);
      if (e_out) *e_out = e;
      return *std::max_element(e.begin(), e.end()) - *std::min_element(e.begin(), e.end());
    };
    // Mean shift in posterior sd per hyperparameter: Cov_d(θ_j, E) / sd_j.
    auto shifts_of = [&](const std::vector<double>& e) {
      std::array<double, fleet::kHyperCount> sh{};
      const double em = std::accumulate(e.begin(), e.end(), 0.0) / D;
      for (int h = 0; h < fleet::kHyperCount; ++h) {
        double tm = 0.0;
        for (int d = 0; d < D; ++d) tm += draws[static_cast<std::size_t>(d)].theta[static_cast<std::size_t>(h)] / D;
        double cov = 0.0, var = 0.0;
        for (int d = 0; d < D; ++d) {
          const double dt = draws[static_cast<std::size_t>(d)].theta[static_cast<std::size_t>(h)] - tm;
          cov += dt * (e[static_cast<std::size_t>(d)] - em) / (D - 1);
          var += dt * dt / (D - 1);
        }
        sh[static_cast<std::size_t>(h)] = cov / std::sqrt(var);
      }
      return sh;
    };
    // The trucks whose error varies most over the draws (total; lateral).
    {
      std::vector<std::pair<double, std::size_t>> per;
      for (std::size_t s = 0; s < subset.size(); ++s) {
        double a = 1e300, b = -1e300;
        for (int d = 0; d < D; ++d) {
          const double e = source(l[s][static_cast<std::size_t>(d)], 0);
          a = std::min(a, e);
          b = std::max(b, e);
        }
        per.emplace_back(b - a, s);
      }
      std::sort(per.rbegin(), per.rend());
      std::cout << "per-truck max-min over draws (nats), largest: ";
      for (std::size_t k = 0; k < std::min<std::size_t>(5, per.size()); ++k)
        std::cout << (k ? ", " : "") << "truck " << subset[per[k].second] << " " << fmt_g(per[k].first);
      double med = per[per.size() / 2].first;
      std::cout << "; median " << fmt_g(med) << "\n";
    }
    {
      int below = 0;
      double least_ratio = 1e300;
      for (int d = 0; d < D; ++d) {
        const fleet::HyperVector& t = draws[static_cast<std::size_t>(d)].theta;
        const double ratio = std::min(t[fleet::kSigmaK] / lattice.dk_npm, t[fleet::kSigmaKt] / lattice.dkt_npm);
        least_ratio = std::min(least_ratio, ratio);
        if (ratio < model::FleetMarginal::kMinSdPerSpacing) ++below;
      }
      const double floor = model::FleetMarginal::kMinSdPerSpacing;
      std::cout << "draws with a fleet sd below FleetMarginal's floor (" << floor << " spacings: "
                << fmt_g(floor * lattice.dk_npm) << ", " << fmt_g(floor * lattice.dkt_npm) << " N/m): " << below << " of "
                << D << "; least fleet sd over spacing among the draws " << fmt_g(least_ratio) << "\n";
    }
    std::vector<std::size_t> all_s(subset.size());
    std::iota(all_s.begin(), all_s.end(), std::size_t{0});
    constexpr int kBoot = 400;
    std::mt19937_64 boot_rng(77);
    std::uniform_int_distribution<std::size_t> pick(0, subset.size() - 1);
    std::vector<std::vector<std::size_t>> boots(kBoot);
    for (auto& b : boots)
      for (std::size_t k = 0; k < subset.size(); ++k) b.push_back(pick(boot_rng));
    auto sd_of = [](const std::vector<double>& v) {
      const double mu = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
      double s2 = 0.0;
      for (double x : v) s2 += (x - mu) * (x - mu);
      return std::sqrt(s2 / static_cast<double>(v.size() - 1));
    };

    std::cout << "\n## " << config << "\n\n"
              << "cost: fit " << fmt(cost.wall_s, 1) << " s (" << fmt(trucks / cost.wall_s, 1) << " trucks/s), tables "
              << fmt(1e3 * cost.table_s / trucks, 2) << " ms/truck, " << fmt(cost.passes_per_truck, 0)
              << " integrator passes/truck, " << fmt(cost.entries_per_table, 1) << " entries/table, " << cost.rebuilds
              << " rebuilds; sigma_ref " << fmt_g(cost.sigma_ref) << ", lattice (" << fmt_g(cost.lattice.dk_npm) << ", "
              << fmt_g(cost.lattice.dkt_npm) << ") N/m; reference " << fmt(ref_s, 1) << " s, " << ref_passes / static_cast<long long>(subset.size())
              << " passes/truck\n";
    if (first)
      std::cout << "reference refined x" << refine + 1 << " on " << check_trucks << " trucks: max |change| "
                << fmt_g(check_max) << " nats, max-min of the change over draws " << fmt_g(check_spread) << "\n";
    {
      double mean_abs = 0.0, max_abs = 0.0, mean_off = 0.0;
      for (std::size_t s = 0; s < subset.size(); ++s) {
        const double e = source(l[s][DD - 1], 0);
        mean_abs += std::abs(e) / static_cast<double>(subset.size());
        mean_off += e / static_cast<double>(subset.size());
        max_abs = std::max(max_abs, std::abs(e));
      }
      std::cout << "per truck at the posterior mean, table - exact: mean " << fmt_g(mean_off) << ", mean |.| "
                << fmt_g(mean_abs) << ", max |.| " << fmt_g(max_abs) << " nats\n\n";
    }
    std::cout << "| source | max-min of E over draws (nats, n=" << trucks << ") | bootstrap sd | sd over draws | x sqrt(10) (n=10^4, smooth error) | x 10 (fixed spread per truck) |";
    for (int h = 0; h < fleet::kHyperCount; ++h) std::cout << " shift " << fleet::kHyperNames[h] << " (sd) |";
    std::cout << "\n|---|---|---|---|---|---|";
    for (int h = 0; h < fleet::kHyperCount; ++h) std::cout << "---|";
    std::cout << "\n";
    for (int src = 0; src < kSources; ++src) {
      std::vector<double> e;
      const double spread = spread_of(all_s, src, &e);
      std::vector<double> bs;
      std::vector<std::array<double, fleet::kHyperCount>> bshift;
      for (const auto& b : boots) {
        std::vector<double> eb;
        bs.push_back(spread_of(b, src, &eb));
        bshift.push_back(shifts_of(eb));
      }
      const auto sh = shifts_of(e);
      std::cout << "| " << kSourceNames[src] << " | " << fmt(spread, 3) << " | " << fmt(sd_of(bs), 3) << " | "
                << fmt(sd_of(e), 3) << " | " << fmt(spread * std::sqrt(10.0), 2) << " | " << fmt(spread * 10.0, 2) << " |";
      for (int h = 0; h < fleet::kHyperCount; ++h) {
        std::vector<double> col;
        for (const auto& b : bshift) col.push_back(b[static_cast<std::size_t>(h)]);
        std::cout << " " << fmt(sh[static_cast<std::size_t>(h)], 3) << " ± " << fmt(sd_of(col), 3) << " |";
      }
      std::cout << "\n";
    }
    std::cout.flush();
  }
  return 0;
}
