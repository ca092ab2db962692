// Interpolation in a model extension's ψ (model/psi_grid.hpp) and tables built under an extension
// at a fixed ψ (TruckTableOptions::forward).
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_marginal.hpp"
#include "model/model_extension.hpp"
#include "model/psi_grid.hpp"
#include "model/truck_search.hpp"
#include "model/truck_table.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

template <class V>
bool same_bytes(const V& a, const V& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
}

bool same_bits(const model::TruckTable& a, const model::TruckTable& b) {
  return same_bytes(a.k_index, b.k_index) && same_bytes(a.kt_index, b.kt_index) && same_bytes(a.c, b.c) &&
         same_bytes(a.m, b.m) && same_bytes(a.b, b.b) && same_bytes(a.z_mean_m, b.z_mean_m) &&
         same_bytes(a.z_var_m2, b.z_var_m2) &&
         std::memcmp(&a.z_var_ref_m2, &b.z_var_ref_m2, sizeof(double)) == 0 && a.passes == b.passes &&
         a.nodes_evaluated == b.nodes_evaluated && std::memcmp(&a.fit, &b.fit, sizeof(model::TruckFit)) == 0;
}

// Table options as the marginal core sets them for the Table 1 fleet near its posterior.
model::TruckTableOptions table1_options() {
  model::TruckTableOptions o;
  o.sigma_ref = 0.02;
  o.population = model::TruckTableOptions::Population{500e3, 65e3, 1950e3, 255e3};
  o.k_start_npm = 500e3;
  o.kt_start_npm = 1950e3;
  o.start_is_close = true;
  o.max_piece_sd_m = 0.083;  // σ_z / 6, σ_z = 0.5 m
  return o;
}

}  // namespace

TEST_CASE("psi grid nodes are Chebyshev points of the second kind, ends included", "[psi_grid]") {
  const model::PsiGrid g(2.0, 6.0, 5);
  REQUIRE(g.size() == 5);
  CHECK(g.nodes()[0] == 2.0);
  CHECK(g.nodes()[2] == 4.0);
  CHECK(g.nodes()[4] == 6.0);
  CHECK(g.nodes()[1] == Approx(4.0 - 2.0 * std::sqrt(0.5)).epsilon(1e-15));
  CHECK(model::PsiGrid(2.0, 6.0, 1).nodes() == std::vector<double>{4.0});
  CHECK_THROWS_AS(model::PsiGrid(1.0, 1.0, 3), UsageError);
  CHECK_THROWS_AS(model::PsiGrid(0.0, 1.0, 0), UsageError);
}

TEST_CASE("psi grid interpolation is exact for polynomials of degree below Q", "[psi_grid]") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> coef(-1.0, 1.0);
  // An interval like a vehicle constant's (c_t in N s/m), far from 0, so the test also covers the
  // scaling: p(ψ) = Σ a_j ((ψ - c) / h)^j with |a_j| ≤ 1, so |p| ≤ Q on the interval and the
  // barycentric form's rounding error is a few hundred ulps of that.
  const double lo = 800.0, hi = 1400.0, c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  for (int Q = 1; Q <= 9; ++Q) {
    const model::PsiGrid g(lo, hi, Q);
    for (int trial = 0; trial < 5; ++trial) {
      std::vector<double> a(static_cast<std::size_t>(Q));
      for (double& x : a) x = coef(rng);
      auto p = [&](double psi) {
        double s = 0.0, t = 1.0;
        for (double aj : a) {
          s += aj * t;
          t *= (psi - c) / h;
        }
        return s;
      };
      std::vector<double> values;
      for (double x : g.nodes()) values.push_back(p(x));
      for (int j = 0; j <= 40; ++j) {
        const double psi = lo + (hi - lo) * j / 40.0;
        CHECK(std::abs(g.interpolate(values.data(), psi) - p(psi)) < 1e-12 * Q);
      }
    }
    // The weights add to one everywhere (a constant offset in ℓ passes through unchanged) and pick
    // a node's value out exactly at the node.
    const std::vector<double> w = g.weights(lo + 0.3 * (hi - lo));
    double sum = 0.0;
    for (double x : w) sum += x;
    CHECK(sum == Approx(1.0).epsilon(1e-14));
    const std::vector<double> at_node = g.weights(g.nodes().back());
    CHECK(at_node.back() == 1.0);
    for (std::size_t j = 0; j + 1 < at_node.size(); ++j) CHECK(at_node[j] == 0.0);
  }
  // A degree-Q polynomial is not reproduced by Q nodes (the test above could fail).
  const model::PsiGrid g3(0.0, 1.0, 3);
  const std::vector<double> cube{0.0, 0.125, 1.0};
  CHECK(std::abs(g3.interpolate(cube.data(), 0.25) - 0.015625) > 1e-3);
}

TEST_CASE("the psi window follows the posterior and tells a narrowed posterior from a moved one",
          "[psi_grid]") {
  model::PsiWindowRule rule;
  rule.half_width_sd = 6.0;
  // Broad: the box.
  model::PsiWindow w = model::psi_window(rule, 5e3, 4e3, 0.0, 10e3);
  CHECK(w.lo == 0.0);
  CHECK(w.hi == 10e3);
  // Narrow: mean ± 6 sd.
  w = model::psi_window(rule, 1000.0, 50.0, 0.0, 10e3);
  CHECK(w.lo == Approx(700.0));
  CHECK(w.hi == Approx(1300.0));
  // Against an end of the box: clipped.
  w = model::psi_window(rule, 100.0, 50.0, 0.0, 10e3);
  CHECK(w.lo == 0.0);
  CHECK(w.hi == Approx(400.0));
  const model::PsiWindow current{700.0, 1300.0};
  using Check = model::PsiWindowCheck;
  CHECK(model::check_psi_window(rule, current, 1000.0, 50.0, 0.0, 10e3) == Check::kKeep);
  CHECK(model::check_psi_window(rule, current, 1050.0, 50.0, 0.0, 10e3) ==
        Check::kKeep);  // ±4 sd still inside
  CHECK(model::check_psi_window(rule, current, 1150.0, 50.0, 0.0, 10e3) ==
        Check::kMoved);  // 1150 + 200 > 1300
  CHECK(model::check_psi_window(rule, current, 1000.0, 20.0, 0.0, 10e3) ==
        Check::kNarrowed);                                                                 // 240 < 0.5 x 600
  CHECK(model::check_psi_window(rule, current, 1000.0, 30.0, 0.0, 10e3) == Check::kKeep);  // 360 > 300
  // Against the box's end the window need not reach past it.
  CHECK(model::check_psi_window(rule, {0.0, 400.0}, 100.0, 50.0, 0.0, 10e3) == Check::kKeep);
  CHECK_THROWS_AS(model::psi_window(rule, 1.0, 0.0, 0.0, 10e3), UsageError);
}

TEST_CASE("a table under an extension at its null value is the base table, bit for bit",
          "[psi_grid][truck_table]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks =
      fleet::draw_fleet(fleet::FleetDistribution{}, 4, site.lateral_min_m(), site.lateral_max_m(), 21);
  const auto tyre = fleet::make_extension("tyre_damping", site);
  const auto speed = fleet::make_extension("speed_bias", site);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 21, *tyre, {1000.0});
  const model::TruckTableOptions base = table1_options();
  const model::Lattice lattice{500e3, 11e3, 1950e3, 75e3};
  for (const auto& r : log.records) {
    const model::TruckTable t0 =
        model::build_truck_table(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, lattice, base);
    for (const fleet::ModelExtension* ext : {tyre.get(), speed.get()}) {
      model::TruckTableOptions o = base;
      o.forward = model::ForwardEdit{ext, {ext->parameters()[0].null_value}};
      const model::TruckTable t1 =
          model::build_truck_table(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, lattice, o);
      CHECK(same_bits(t0, t1));
    }
    // Away from the null value the table differs (so the check above could fail).
    model::TruckTableOptions o = base;
    o.forward = model::ForwardEdit{tyre.get(), {1000.0}};
    const model::TruckTable t2 =
        model::build_truck_table(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, lattice, o);
    CHECK_FALSE(same_bits(t0, t2));
    CHECK(t2.passes > 0);
  }
  // ψ of the wrong size is refused.
  model::TruckTableOptions bad = base;
  bad.forward = model::ForwardEdit{tyre.get(), {}};
  const auto& r = log.records[0];
  CHECK_THROWS_AS(
      model::build_truck_table(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, lattice, bad),
      UsageError);
}

TEST_CASE("a truck's likelihood interpolated between tables at psi nodes matches a table built at psi",
          "[psi_grid][truck_table]") {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks =
      fleet::draw_fleet(fleet::FleetDistribution{}, 6, site.lateral_min_m(), site.lateral_max_m(), 31);
  const auto tyre = fleet::make_extension("tyre_damping", site);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 31, *tyre, {1000.0});
  const model::TruckTableOptions base = table1_options();
  const model::Lattice lattice{500e3, 11e3, 1950e3, 75e3};
  const model::FleetMarginal marginal(
      site.sensors(), fleet::LateralRange{site.lateral_min_m(), site.lateral_max_m()}, lattice);
  const model::ThetaTerms terms = marginal.prepare({500e3, 50e3, 1.5e6, 196e3, 1.5, 0.5, 0.02});
  auto ell = [&](const records::WimRecord& r, double psi) {
    model::TruckTableOptions o = base;
    o.forward = model::ForwardEdit{tyre.get(), {psi}};
    return marginal.log_likelihood(
        model::build_truck_table(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, lattice, o), terms);
  };
  // The window ± 6 posterior sd at 1,000 trucks around c_t ≈ 700 N s/m, Q = 5, as the benchmark
  // measured it (benchmarks/results/2026-11-28-psi-grid.md: 40 trucks x 9 ψ of that window, the
  // largest |interpolated - direct| 3.5e-5 nats per truck, the tables' own noise in ψ; with Q = 3
  // on the whole box it is 0.6). The bound is 6 times the largest seen.
  const model::PsiGrid grid(250.0, 1150.0, 5);
  const double between = 0.5 * (grid.nodes()[1] + grid.nodes()[2]);
  for (const auto& r : log.records) {
    std::vector<double> at_nodes;
    for (double x : grid.nodes()) at_nodes.push_back(ell(r, x));
    const double direct = ell(r, between);
    CHECK(std::abs(grid.interpolate(at_nodes.data(), between) - direct) < 2e-4);
  }
}

TEST_CASE("line-bundled passes under an extension agree with the extended forward model",
          "[psi_grid][truck_table]") {
  // The table's two routes to a pass under an edit: simulate_on_lines (pass edits in the cars'
  // constants and the speed, an added profile as one extra pass per node, output edits per
  // column) and simulate (the extended forward model, pass by pass), at z on the same lines.
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const std::vector<double> k{420e3, 500e3, 610e3}, kt{1.7e6, 1.95e6, 2.3e6};
  const Eigen::Index first_line = 10, lines = 4;
  const vehicle::LineBundle bundle = site.line_bundle(first_line, lines);
  const struct {
    const char* name;
    std::vector<double> psi;
  } cases[] = {{"tyre_damping", {2000.0}},  {"suspension_damping", {35e3}},
               {"unsprung_mass", {600.0}},  {"speed_bias", {1.05}},
               {"sensor_gain", {5.0, 1.1}}, {"profile_defect", {0.0, 0.5, 0.01}}};
  for (const auto& c : cases) {
    const auto ext = fleet::make_extension(c.name, site);
    std::vector<double> psi = c.psi;
    if (std::string(c.name) == "profile_defect") psi[0] = ext->parameters()[0].null_value;  // mid-site
    const model::ForwardEdit edit{ext.get(), psi};
    const Eigen::ArrayXXd on_lines =
        model::detail::simulate_on_lines(site, 22.0, 4400.0, k, kt, bundle, util::serial_range, &edit);
    std::vector<double> kk, kkt, z;
    for (std::size_t n = 0; n < k.size(); ++n) {
      for (Eigen::Index l = 0; l < lines; ++l) {
        kk.push_back(k[n]);
        kkt.push_back(kt[n]);
        z.push_back(site.surface().lateral_m(first_line + l));
      }
    }
    const Eigen::ArrayXXd passes =
        model::detail::simulate(site, 22.0, 4400.0, kk, kkt, z, util::serial_range, &edit);
    const Eigen::ArrayXXd base = model::detail::simulate(site, 22.0, 4400.0, kk, kkt, z);
    INFO(c.name);
    REQUIRE(on_lines.cols() == passes.cols());
    // run_on_lines and run_batch agree to rounding (pass_integrator.hpp); the edit is felt.
    CHECK((on_lines - passes).abs().maxCoeff() < 1e-10);
    CHECK((passes - base).abs().maxCoeff() > 1e-4);
  }
}
