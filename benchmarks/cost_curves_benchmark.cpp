// Cost curves for a log-log plot: per-truck wall time against the
// number of trucks n, for the three ways ssrfleet can fit a log.
//   - the latent core (fleet::FleetSmc, `fit --core latent`: 1,024 particles, 2 threads, seed 1,
//     the same trucks as scale_benchmark: Table 1 fleet, AS1, σ_IF = 0.02, simulated in chunks of
//     1,000 with seed 1 + chunk): every absorb() timed, the mean over (n/2, n] for n = 2, 4, ...,
//     as scale_benchmark does for the marginal core, until --latent-trucks or --budget seconds
//     (its cost per truck grows with n: it "stops" where a user would stop it);
//   - the batch MCMC, from a ratio_benchmark JSON (--ratio FILE): its time to ESS 400 at each N
//     it measured, divided by N (an offline fit, amortised per truck) and whole (an online fit
//     that re-runs the MCMC for each new truck).
// The marginal core's curve is scale_benchmark's (--curve). Writes CSVs for
// benchmarks/results/cost-curves.gp, which draws docs/scale_curve.png from all three.
//
//   cost_curves_benchmark [--latent-trucks 512 (0: skip)] [--budget 900] [--ratio FILE]
//                         [--latent-curve FILE] [--mcmc-curve FILE]
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleet/fleet_smc.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "run_info.hpp"
#include "site/road_source.hpp"

using namespace ssrfleet;

namespace {

double window_mean_ms(const std::vector<double>& ms, std::size_t a, std::size_t b) {
  double s = 0.0;
  for (std::size_t i = a; i < b; ++i) s += ms[i];
  return b > a ? s / static_cast<double>(b - a) : NAN;
}

// The latent core's per-truck wall times (ms), in arrival order.
std::vector<double> latent_core_times(long trucks, double budget_s) {
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  fleet::FleetSmc::Options o;  // `fit --core latent`'s defaults
  o.sampler.particles = 1024;
  o.sampler.threads = 2;
  o.sampler.seed = 1;
  fleet::FleetSmc smc(site, o);
  std::vector<double> ms;
  const auto started = std::chrono::steady_clock::now();
  long n = 0;
  for (long chunk = 0; n < trucks; ++chunk) {
    const auto seed = static_cast<std::uint64_t>(1 + chunk);
    const int count = static_cast<int>(std::min<long>(1000, trucks - n));
    const auto fleet_trucks =
        fleet::draw_fleet(fleet::FleetDistribution{}, count, site.lateral_min_m(), site.lateral_max_m(), seed);
    const fleet::SimulatedLog log = fleet::simulate_log(site, fleet_trucks, 0.02, seed);
    for (const auto& r : log.records) {
      const auto t0 = std::chrono::steady_clock::now();
      smc.absorb(r);
      ms.push_back(1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      ++n;
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      if ((n & (n - 1)) == 0)
        std::cerr << "latent core: n=" << n << ", last truck " << std::fixed << std::setprecision(1) << ms.back()
                  << " ms, " << elapsed << " s in all\n";
      if (n >= trucks || elapsed > budget_s) return ms;
    }
  }
  return ms;
}

}  // namespace

int main(int argc, char** argv) {
  long latent_trucks = 512;
  double budget_s = 900.0;
  std::string ratio_path, latent_curve = "benchmarks/results/cost-latent-curve.csv",
                          mcmc_curve = "benchmarks/results/cost-mcmc-curve.csv";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--latent-trucks") latent_trucks = std::stol(next());
    else if (a == "--budget") budget_s = std::stod(next());
    else if (a == "--ratio") ratio_path = next();
    else if (a == "--latent-curve") latent_curve = next();
    else if (a == "--mcmc-curve") mcmc_curve = next();
    else {
      std::cerr << "usage: cost_curves_benchmark [--latent-trucks N] [--budget S] [--ratio FILE]\n"
                   "                             [--latent-curve FILE] [--mcmc-curve FILE]\n";
      return a == "--help" ? 0 : 64;
    }
  }
  if ((latent_trucks != 0 && latent_trucks < 2) || !(budget_s > 0.0)) {
    std::cerr << "cost_curves_benchmark: --latent-trucks must be 0 (skip) or >= 2, and --budget positive\n";
    return 64;
  }

  if (!ratio_path.empty()) {
    std::ifstream in(ratio_path);
    if (!in) {
      std::cerr << "cost_curves_benchmark: cannot read " << ratio_path << "\n";
      return 66;
    }
    // A ratio_benchmark JSON; anything else is an error naming the file, not a crash.
    std::vector<std::array<double, 2>> points;  // (trucks, MCMC time to ESS 400)
    try {
      const nlohmann::json j = nlohmann::json::parse(in);
      for (const auto& r : j.at("results")) {
        const auto& m = r.at("mcmc");
        points.push_back({r.at("trucks").get<double>(),
                          m.at("reached_ess_400").get<bool>() ? m.at("time_to_ess_400_s").get<double>()
                                                              : m.at("extrapolated_time_to_400_s").get<double>()});
      }
    } catch (const nlohmann::json::exception& e) {
      std::cerr << "cost_curves_benchmark: " << ratio_path << ": not a ratio_benchmark result: " << e.what() << "\n";
      return 65;
    }
    std::ofstream out(mcmc_curve);
    out << "trucks,mcmc_time_to_400_s,amortised_ms_per_truck,rerun_ms_per_truck\n";
    for (const auto& [n, t] : points) out << n << "," << t << "," << 1e3 * t / n << "," << 1e3 * t << "\n";
    std::cerr << "wrote " << mcmc_curve << "\n";
  }

  if (latent_trucks == 0) return 0;
  const double load_before = bench::load_average_1min();
  const std::vector<double> ms = latent_core_times(latent_trucks, budget_s);
  std::ofstream out(latent_curve);
  out << "# latent core (FleetSmc, 1024 particles, 2 threads), mean wall ms per truck over (n/2, n]; "
      << ms.size() << " trucks, load " << load_before << " -> " << bench::load_average_1min() << ", "
      << bench::utc_now() << ", commit " << bench::run_command("git rev-parse --short HEAD 2>/dev/null") << "\n";
  out << "window_end_n,mean_ms_per_truck\n";
  for (std::size_t n = 2; n <= ms.size(); n *= 2) out << n << "," << window_mean_ms(ms, n / 2, n) << "\n";
  std::cerr << "wrote " << latent_curve << " (" << ms.size() << " trucks)\n";
  return 0;
}
