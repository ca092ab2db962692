// Whether a one-parameter model extension's ψ can be carried by the marginal core as tables at a
// few ψ nodes and interpolation between them (model/psi_grid.hpp). On a simulated log with the
// effect hidden at `--truth`, θ at the generating values:
//   profile  S(ψ) = Σ_i ℓ_i(θ*, ψ) from tables built directly at 15 ψ around its peak (a coarse
//            scan of the prior box on a subset finds the peak first); a quadratic least-squares
//            fit gives the peak and the curvature, so ψ's posterior sd given θ* at n trucks, and
//            (× √(n / n')) at n'.
//   interp   E(ψ) = Σ_i (ℓ_i,interp(θ, ψ) - ℓ_i,direct(θ, ψ)) on a subset of trucks at 9 ψ spread
//            across each window, for Q = 3, 5, 7, 9 Chebyshev nodes (17 and 33 on the box, and the
//            box also in log ψ when positive). Windows: the prior box, and the profile peak ± 6
//            posterior sd at n = 20, 50, 200, 1,000, 10,000 and ± 4 at the last two (the sd given
//            θ*, a lower bound on the marginal sd: real windows are wider). Reported: max - min of
//            E over the 9 ψ per truck and scaled to the window's n (× n / subset: exact if every
//            truck erred alike, an over-estimate if their errors are independent), at θ* and at θ*
//            moved by one posterior sd at that n in K (sd ≈ √(σ_k² + lik_k²) / √n) and in σ_z
//            (sd ≈ σ_z / √(2n)).
//   cost     integrator passes and wall ms per table: the base model's table, the extension's at
//            its null value (whose bits must equal the base table's: counted), and at the truth.
//
// An extension of several parameters is scanned in its last one with the others held at --fixed
// (e.g. sensor_gain: --fixed 5 scans sensor 5's gain); the data are made at (fixed, truth).
//
//   psi_grid_benchmark --effect tyre_damping --truth 1000 [--trucks 200] [--subset 30] [--seed 7]
//                      [--threads 2] [--fixed v1,v2,...]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Dense>

#include "fleet_presets.hpp"
#include "model/fleet_marginal.hpp"
#include "model/model_extension.hpp"
#include "model/psi_grid.hpp"
#include "model/truck_table.hpp"
#include "run_info.hpp"
#include "site/road_source.hpp"

using namespace ssrfleet;

namespace {

using clock_type = std::chrono::steady_clock;

struct Built {
  model::TruckTable table;
  double ms = 0.0;
};

struct Setup {
  const site::Site* site = nullptr;
  const fleet::SimulatedLog* log = nullptr;
  const fleet::ModelExtension* extension = nullptr;
  model::TruckTableOptions options;
  model::Lattice lattice;
  int threads = 2;
};

// Tables of trucks [0, count) at ψ (no extension: psi empty), one truck per thread at a time.
std::vector<Built> build_tables(const Setup& s, int count, const std::vector<double>& psi) {
  std::vector<Built> out(static_cast<std::size_t>(count));
  std::atomic<int> next{0};
  auto work = [&] {
    model::TruckTableOptions o = s.options;
    if (!psi.empty()) o.forward = model::ForwardEdit{s.extension, psi};
    for (int i = next++; i < count; i = next++) {
      const records::WimRecord& r = s.log->records[static_cast<std::size_t>(i)];
      const auto t0 = clock_type::now();
      out[static_cast<std::size_t>(i)].table =
          model::build_truck_table(*s.site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, s.lattice, o);
      out[static_cast<std::size_t>(i)].ms =
          std::chrono::duration<double, std::milli>(clock_type::now() - t0).count();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < s.threads; ++t) pool.emplace_back(work);
  for (auto& t : pool) t.join();
  return out;
}

bool same_bits(const model::TruckTable& a, const model::TruckTable& b) {
  auto eq = [](const auto& x, const auto& y) {
    return x.size() == y.size() &&
           (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
  };
  return eq(a.k_index, b.k_index) && eq(a.kt_index, b.kt_index) && eq(a.c, b.c) && eq(a.m, b.m) &&
         eq(a.b, b.b) && eq(a.z_mean_m, b.z_mean_m) && eq(a.z_var_m2, b.z_var_m2) &&
         std::memcmp(&a.z_var_ref_m2, &b.z_var_ref_m2, sizeof(double)) == 0 && a.passes == b.passes;
}

struct CostRow {
  double passes = 0.0, ms = 0.0, entries = 0.0;
};
CostRow cost_of(const std::vector<Built>& tables) {
  CostRow c;
  for (const Built& b : tables) {
    c.passes += b.table.passes;
    c.ms += b.ms;
    c.entries += static_cast<double>(b.table.nodes());
  }
  const double n = static_cast<double>(tables.size());
  return {c.passes / n, c.ms / n, c.entries / n};
}

// Least-squares quadratic a + b x + c x² through (x, y).
Eigen::Vector3d fit_quadratic(const std::vector<double>& x, const std::vector<double>& y) {
  Eigen::MatrixXd A(static_cast<Eigen::Index>(x.size()), 3);
  Eigen::VectorXd v(static_cast<Eigen::Index>(x.size()));
  for (std::size_t i = 0; i < x.size(); ++i) {
    A(static_cast<Eigen::Index>(i), 0) = 1.0;
    A(static_cast<Eigen::Index>(i), 1) = x[i];
    A(static_cast<Eigen::Index>(i), 2) = x[i] * x[i];
    v[static_cast<Eigen::Index>(i)] = y[i];
  }
  return A.colPivHouseholderQr().solve(v);
}

const char* arg(int argc, char** argv, const char* name, const char* fallback) {
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return argv[i + 1];
  return fallback;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string effect = arg(argc, argv, "--effect", "tyre_damping");
  const double truth = std::atof(arg(argc, argv, "--truth", "1000"));
  const int n_trucks = std::atoi(arg(argc, argv, "--trucks", "200"));
  const int subset = std::min(n_trucks, std::atoi(arg(argc, argv, "--subset", "30")));
  const std::uint64_t seed = std::strtoull(arg(argc, argv, "--seed", "7"), nullptr, 10);
  const int threads = std::atoi(arg(argc, argv, "--threads", "2"));
  std::vector<double> fixed;
  for (const char* p = arg(argc, argv, "--fixed", ""); *p != '\0';) {
    char* end = nullptr;
    fixed.push_back(std::strtod(p, &end));
    p = (*end == ',') ? end + 1 : end;
  }

  const auto t_start = clock_type::now();
  std::printf("psi_grid_benchmark --effect %s --truth %g --trucks %d --subset %d --seed %llu --threads %d\n",
              effect.c_str(), truth, n_trucks, subset, static_cast<unsigned long long>(seed), threads);
  for (double v : fixed) std::printf("  fixed leading parameter %g\n", v);
  std::printf("run %s, load %.2f, commit %s\n", bench::utc_now().c_str(), bench::load_average_1min(),
              bench::run_command("git rev-parse --short HEAD 2>/dev/null").c_str());

  const bench::FleetPreset preset = bench::table1_fleet();
  const site::Site site(site::load_road(preset.road), site::SiteOptions{});
  const std::unique_ptr<fleet::ModelExtension> ext = fleet::make_extension(effect, site);
  if (ext->dim() != static_cast<Eigen::Index>(fixed.size()) + 1) {
    std::fprintf(stderr, "%s has %d parameters: give all but the last with --fixed\n", effect.c_str(),
                 static_cast<int>(ext->dim()));
    return 2;
  }
  // ψ with the scanned parameter at x.
  auto full = [&](double x) {
    std::vector<double> psi = fixed;
    psi.push_back(x);
    return psi;
  };
  const fleet::ExtensionParameter& par = ext->parameters().back();
  const double box_lo = par.lo, box_hi = par.hi;
  const std::vector<records::Truck> drawn =
      fleet::draw_fleet(preset.distribution, n_trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  const fleet::SimulatedLog log = fleet::simulate_log(site, drawn, preset.sigma_if, seed, *ext, full(truth));
  const fleet::HyperVector th = preset.truth();
  std::printf("effect %s, parameter %s in [%g, %g] %s, null %g, truth %g; fleet %s on %s, sigma_IF %g\n",
              effect.c_str(), par.name.c_str(), box_lo, box_hi, par.unit.c_str(), par.null_value, truth,
              preset.name.c_str(), preset.road.c_str(), preset.sigma_if);

  // Table options as MarginalTarget sets them once the posterior is near the truth.
  Setup s;
  s.site = &site;
  s.log = &log;
  s.extension = ext.get();
  s.threads = threads;
  s.options.sigma_ref = th[fleet::kSigmaIf];
  s.options.population = model::TruckTableOptions::Population{th[fleet::kK], 1.3 * th[fleet::kSigmaK],
                                                              th[fleet::kKt], 1.3 * th[fleet::kSigmaKt]};
  s.options.k_start_npm = th[fleet::kK];
  s.options.kt_start_npm = th[fleet::kKt];
  s.options.start_is_close = true;
  s.options.max_piece_sd_m = std::clamp(th[fleet::kSigmaZ] / 6.0, 0.04, 0.1);
  // The lattice: spacing 1.0 of the integrand's width (likelihood sd at σ_ref, geometric mean
  // over the trucks' fits under the truth, with the fleet sd).
  double sum_log_k = 0.0, sum_log_kt = 0.0;
  {
    model::TruckTableOptions o = s.options;
    o.forward = model::ForwardEdit{ext.get(), full(truth)};
    for (const auto& r : log.records) {
      const model::TruckFit f = model::fit_truck(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, o);
      sum_log_k += std::log(f.stiffness_sd_per_sigma);
      sum_log_kt += std::log(f.tyre_stiffness_sd_per_sigma);
    }
  }
  const double lik_k = std::exp(sum_log_k / n_trucks) * s.options.sigma_ref;
  const double lik_kt = std::exp(sum_log_kt / n_trucks) * s.options.sigma_ref;
  const double width_k = 1.0 / std::sqrt(1.0 / (lik_k * lik_k) + 1.0 / std::pow(th[fleet::kSigmaK], 2));
  const double width_kt = 1.0 / std::sqrt(1.0 / (lik_kt * lik_kt) + 1.0 / std::pow(th[fleet::kSigmaKt], 2));
  s.lattice = model::Lattice{th[fleet::kK], width_k, th[fleet::kKt], width_kt};
  std::printf("lattice dk %.0f dkt %.0f N/m (likelihood sd at sigma_ref: k %.0f, kt %.0f)\n", width_k,
              width_kt, lik_k, lik_kt);

  const model::FleetMarginal marginal(
      site.sensors(), fleet::LateralRange{site.lateral_min_m(), site.lateral_max_m()}, s.lattice);
  // θ*, and θ* moved one posterior sd in K and in σ_z at each n of ns.
  const std::vector<int> ns{20, 50, 200, 1000, 10000};
  std::vector<fleet::HyperVector> thetas{th};
  for (int n : ns) {
    fleet::HyperVector a = th, b = th;
    a[fleet::kK] += std::sqrt(th[fleet::kSigmaK] * th[fleet::kSigmaK] + lik_k * lik_k) / std::sqrt(n);
    b[fleet::kSigmaZ] += th[fleet::kSigmaZ] / std::sqrt(2.0 * n);
    thetas.push_back(a);
    thetas.push_back(b);
  }
  std::vector<model::ThetaTerms> terms;
  for (const auto& t : thetas) terms.push_back(marginal.prepare(t));
  // ℓ_i at every θ of `thetas`, trucks [0, count), at ψ (cached by ψ).
  std::map<double, Eigen::MatrixXd> cache;  // ψ -> (truck, θ)
  std::map<double, CostRow> cost_at;
  auto ells = [&](double psi, int count) -> const Eigen::MatrixXd& {
    auto it = cache.find(psi);
    if (it != cache.end() && it->second.rows() >= count) return it->second;
    const std::vector<Built> tables = build_tables(s, count, full(psi));
    Eigen::MatrixXd l(count, static_cast<Eigen::Index>(thetas.size()));
    for (int i = 0; i < count; ++i)
      for (std::size_t t = 0; t < thetas.size(); ++t)
        l(i, static_cast<Eigen::Index>(t)) =
            marginal.log_likelihood(tables[static_cast<std::size_t>(i)].table, terms[t]);
    cost_at[psi] = cost_of(tables);
    return cache[psi] = l;
  };

  // Cost, and the bits at the null value. Each truck's three tables are built one after the other
  // on one thread, so the machine's load (shared, varying) falls alike on the three.
  {
    const std::vector<std::vector<double>> settings{{}, full(par.null_value), full(truth)};
    std::vector<std::vector<Built>> by(settings.size(),
                                       std::vector<Built>(static_cast<std::size_t>(n_trucks)));
    std::atomic<int> next{0};
    auto work = [&] {
      for (int i = next++; i < n_trucks; i = next++) {
        const records::WimRecord& r = log.records[static_cast<std::size_t>(i)];
        for (std::size_t c = 0; c < settings.size(); ++c) {
          model::TruckTableOptions o = s.options;
          if (!settings[c].empty()) o.forward = model::ForwardEdit{ext.get(), settings[c]};
          const auto t0 = clock_type::now();
          Built& b = by[c][static_cast<std::size_t>(i)];
          b.table =
              model::build_truck_table(site, r.speed_mps, r.sprung_mass_kg, r.impact_factor, s.lattice, o);
          b.ms = std::chrono::duration<double, std::milli>(clock_type::now() - t0).count();
        }
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work);
    for (auto& t : pool) t.join();
    const std::vector<Built>& base = by[0];
    const std::vector<Built>& null = by[1];
    const std::vector<Built>& at_truth = by[2];
    int same = 0;
    for (int i = 0; i < n_trucks; ++i)
      same += same_bits(base[static_cast<std::size_t>(i)].table, null[static_cast<std::size_t>(i)].table);
    const CostRow cb = cost_of(base), cn = cost_of(null), ct = cost_of(at_truth);
    std::printf("\ncost per table (%d trucks, interleaved): passes, ms, entries\n", n_trucks);
    std::printf("  base model            %8.0f %7.2f %6.1f\n", cb.passes, cb.ms, cb.entries);
    std::printf("  %s at null %-8g %8.0f %7.2f %6.1f  (bits equal to base: %d of %d tables)\n",
                effect.c_str(), par.null_value, cn.passes, cn.ms, cn.entries, same, n_trucks);
    std::printf("  %s at truth %-7g %8.0f %7.2f %6.1f\n", effect.c_str(), truth, ct.passes, ct.ms,
                ct.entries);
    double s_base = 0.0, s_truth = 0.0;
    for (int i = 0; i < n_trucks; ++i) {
      s_base += marginal.log_likelihood(base[static_cast<std::size_t>(i)].table, terms[0]);
      s_truth += marginal.log_likelihood(at_truth[static_cast<std::size_t>(i)].table, terms[0]);
    }
    std::printf("  S(theta*) base model %.3f, at the truth %.3f (difference %.3f nats over %d trucks)\n",
                s_base, s_truth, s_truth - s_base, n_trucks);
  }

  // Profile. A coarse scan of the box on the subset, then 15 ψ around its peak on every truck.
  double peak = truth, sd200 = 0.0;
  {
    const model::PsiGrid coarse(box_lo, box_hi, 9);
    std::vector<double> xs, ys;
    for (double x : coarse.nodes()) {
      xs.push_back(x);
      ys.push_back(ells(x, subset).col(0).head(subset).sum() * n_trucks / subset);
    }
    std::printf("\ncoarse scan of the box (%d trucks, scaled to %d):", subset, n_trucks);
    for (std::size_t j = 0; j < xs.size(); ++j) std::printf(" %g:%.1f", xs[j], ys[j] - ys[0]);
    std::printf("\n");
    const auto jmax = static_cast<std::size_t>(std::max_element(ys.begin(), ys.end()) - ys.begin());
    const std::size_t j0 = std::clamp<std::size_t>(jmax, 1, xs.size() - 2);
    const Eigen::Vector3d q =
        fit_quadratic({xs[j0 - 1], xs[j0], xs[j0 + 1]}, {ys[j0 - 1], ys[j0], ys[j0 + 1]});
    double guess_sd = q[2] < 0.0 ? 1.0 / std::sqrt(-2.0 * q[2]) : 0.25 * (box_hi - box_lo);
    double centre = q[2] < 0.0 ? std::clamp(-q[1] / (2.0 * q[2]), xs[j0 - 1], xs[j0 + 1]) : xs[jmax];
    guess_sd = std::min(guess_sd, 0.25 * (box_hi - box_lo));
    // Refine once on the subset: 7 ψ at ± 4 guessed sd.
    {
      std::vector<double> x2, y2;
      for (int j = 0; j < 7; ++j) {
        const double x = std::clamp(centre + guess_sd * (-4.0 + 8.0 * j / 6.0), box_lo, box_hi);
        x2.push_back(x);
        y2.push_back(ells(x, subset).col(0).head(subset).sum() * n_trucks / subset);
      }
      const Eigen::Vector3d q2 = fit_quadratic(x2, y2);
      if (q2[2] < 0.0) {
        guess_sd = 1.0 / std::sqrt(-2.0 * q2[2]);
        centre = std::clamp(-q2[1] / (2.0 * q2[2]), box_lo, box_hi);
      }
    }
    std::vector<double> x3, y3;
    for (int j = 0; j < 15; ++j) {
      const double x = std::clamp(centre + guess_sd * (-4.0 + 8.0 * j / 14.0), box_lo, box_hi);
      if (!x3.empty() && x == x3.back()) continue;
      x3.push_back(x);
      y3.push_back(ells(x, n_trucks).col(0).sum());
    }
    const Eigen::Vector3d q3 = fit_quadratic(x3, y3);
    std::printf("profile S(psi) on %d trucks at theta* (psi: S - S(first)):", n_trucks);
    double rss = 0.0;
    for (std::size_t j = 0; j < x3.size(); ++j) {
      std::printf(" %.6g:%.2f", x3[j], y3[j] - y3[0]);
      const double fitted = q3[0] + q3[1] * x3[j] + q3[2] * x3[j] * x3[j];
      rss += (y3[j] - fitted) * (y3[j] - fitted);
    }
    std::printf("\n");
    if (q3[2] < 0.0) {
      peak = -q3[1] / (2.0 * q3[2]);
      sd200 = 1.0 / std::sqrt(-2.0 * q3[2]);
    } else {
      sd200 = guess_sd;
    }
    std::printf("quadratic fit: peak %.6g (truth %g), sd at n=%d %.4g, rms residual %.3f nats\n", peak, truth,
                n_trucks, sd200, std::sqrt(rss / static_cast<double>(x3.size())));
    for (int n : ns)
      std::printf("  posterior sd of %s given theta* at n=%d: %.4g (%.3g of the box)\n", par.name.c_str(), n,
                  sd200 * std::sqrt(static_cast<double>(n_trucks) / n),
                  sd200 * std::sqrt(static_cast<double>(n_trucks) / n) / (box_hi - box_lo));
  }

  // Interpolation error per window.
  struct Window {
    std::string name;
    int n;
    model::PsiWindow w;  // in the grid's coordinate: ψ, or log ψ if log_scale
    bool log_scale = false;
  };
  std::vector<Window> windows{{"box", n_trucks, {box_lo, box_hi}}};
  // A box of positive ψ also with its nodes evenly spread in log ψ (Chebyshev in log ψ).
  if (box_lo > 0.0) windows.push_back({"box-log", n_trucks, {std::log(box_lo), std::log(box_hi)}, true});
  for (int n : {20, 50, 200, 1000, 10000}) {
    const double sd = sd200 * std::sqrt(static_cast<double>(n_trucks) / n);
    for (double h : {4.0, 6.0}) {
      if (n < 1000 && h < 5.0) continue;  // small n: the ± 6 sd window only
      model::PsiWindowRule rule;
      rule.half_width_sd = h;
      windows.push_back({"+-" + std::to_string(static_cast<int>(h)) + "sd@" + std::to_string(n), n,
                         model::psi_window(rule, peak, sd, box_lo, box_hi)});
    }
  }
  std::printf("\ninterpolation error, max-min over 9 psi of E = sum_i (interp - direct), %d trucks\n",
              subset);
  std::printf(
      "  per truck (nats) and scaled to the window's n; at theta*, K + 1 sd, sigma_z + 1 sd (sd at that "
      "n)\n");
  std::printf("  %-14s %-22s %2s %11s %11s %11s %11s %11s\n", "window", "[lo, hi]", "Q", "per truck",
              "scaled", "scaled K+sd", "scaled sz+sd", "max|e_i|");
  for (const Window& win : windows) {
    // θ columns: 0 = θ*, then (K, σ_z) pairs for each n of ns.
    const int nidx = static_cast<int>(std::find(ns.begin(), ns.end(), win.n) - ns.begin());
    const std::vector<int> cols{0, 1 + 2 * nidx, 2 + 2 * nidx};
    std::vector<double> evals;
    for (int j = 0; j < 9; ++j) evals.push_back(win.w.lo + (win.w.hi - win.w.lo) * (j + 0.5) / 9.0);
    auto psi_of = [&](double u) { return win.log_scale ? std::exp(u) : u; };
    // The box also at Q = 17 and 33 (their nodes hold Q = 9's): a likelihood far from polynomial
    // across the whole box needs more nodes there.
    std::vector<int> qs{3, 5, 7, 9};
    if (win.name.rfind("box", 0) == 0) qs.insert(qs.end(), {17, 33});
    for (int Q : qs) {
      const model::PsiGrid grid(win.w.lo, win.w.hi, Q);
      double range[3] = {0, 0, 0}, max_abs = 0.0;
      for (int c = 0; c < 3; ++c) {
        double lo = 1e300, hi = -1e300;
        for (double x : evals) {
          const std::vector<double> L = grid.weights(x);
          const Eigen::MatrixXd& direct = ells(psi_of(x), subset);
          double e = 0.0;
          for (int i = 0; i < subset; ++i) {
            double interp = 0.0;
            for (int q = 0; q < Q; ++q)
              interp +=
                  L[static_cast<std::size_t>(q)] * ells(psi_of(grid.nodes()[static_cast<std::size_t>(q)]),
                                                        subset)(i, cols[static_cast<std::size_t>(c)]);
            const double ei = interp - direct(i, cols[static_cast<std::size_t>(c)]);
            e += ei;
            if (c == 0) max_abs = std::max(max_abs, std::abs(ei));
          }
          lo = std::min(lo, e);
          hi = std::max(hi, e);
        }
        range[c] = (hi - lo) / subset;
      }
      std::printf("  %-14s [%9.5g, %9.5g] %2d %11.3g %11.3g %11.3g %11.3g %11.3g\n", win.name.c_str(),
                  win.w.lo, win.w.hi, Q, range[0], range[0] * win.n, range[1] * win.n, range[2] * win.n,
                  max_abs);
    }
  }
  // Cost of the tables at every ψ built (passes and ms per table).
  double passes = 0.0, ms = 0.0;
  for (const auto& [psi, c] : cost_at) {
    passes += c.passes;
    ms += c.ms;
  }
  std::printf("\nover the %zu psi values tabulated: mean passes %.0f, mean ms %.2f per table\n",
              cost_at.size(), passes / static_cast<double>(cost_at.size()),
              ms / static_cast<double>(cost_at.size()));
  std::printf("wall %.0f s, load after %.2f\n",
              std::chrono::duration<double>(clock_type::now() - t_start).count(), bench::load_average_1min());
  return 0;
}
