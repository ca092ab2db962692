// Ratio benchmark (issue 14, item 6; DESIGN.md §4): the wall time to an equivalent ESS of 400 on
// all 7 hyperparameters, measured side by side in one run, for
//   (a) the marginal SMC core (fleet::MarginalSmc: default options, 1,024 particles, 2 threads, the
//       log replayed truck by truck, then rejuvenate(final_sweeps)). Its accuracy is measured by
//       seed scatter (seed_scatter.hpp): S fits of the same data with seeds 100, ..., 100 + S - 1;
//       equivalent ESS per hyperparameter = (mean posterior sd)² / (variance of the S posterior
//       means), the smallest over the 7 counts. Time to ESS 400 = mean wall per fit x 400 /
//       smallest equivalent ESS (the Monte Carlo variance of an SMC estimate falls as 1 / particles
//       and the cost grows with them, so the scaling is linear to first order). With S seeds the
//       equivalent ESS is known to a χ²(S - 1) / (S - 1) factor: its 90 % interval is printed.
//   (b) the batch MCMC baseline (fleet::run_batch_mcmc, default options: interweaving on, best-fit
//       start; 2 threads): one long chain; the first prefix of the kept chain (checked every 500
//       sweeps) where the smallest of the 7 chain ESS (Geyer) reaches 400. Time = init_seconds +
//       (burn_in + kept sweeps) x (wall - init) / iterations. If the chain never gets there, the
//       extrapolation from the whole chain is reported separately (and flagged).
//   (c) the cost of one more truck: one absorb() of a fresh simulated truck into each SMC fit after
//       its final sweeps, against re-running the MCMC to ESS 400.
// Data: Table 1 fleet (FleetDistribution defaults), road AS1, σ_IF = 0.02, seed 1 for the fleet draw
// and the noise. The machine may be shared: the 1-minute load average is recorded before and after
// each N.
//
//   ratio_benchmark [--trucks 100,1000] [--trucks N ...] [--seeds 8] [--json FILE] [--markdown FILE]
//                   [--mcmc-iterations I --mcmc-burn-in B] [--commit HASH]
// Default MCMC lengths: 40,000 / 5,000 sweeps at N <= 100, 20,000 / 5,000 above. The results files
// are rewritten after every N, so an interrupted run keeps the finished ones.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "road/surface_presets.hpp"
#include "seed_scatter.hpp"
#include "run_info.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;
using bench::load_average_1min;
using bench::run_command;
using bench::utc_now;

namespace {

using clock_type = std::chrono::steady_clock;

double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}

std::string fmt(double v, int prec = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s << std::fixed << std::setprecision(prec) << v;
  return s.str();
}

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

constexpr double kTargetEss = 400.0;
constexpr int kCheckEvery = 500;

struct SmcResult {
  int seeds = 0;
  std::vector<double> wall_s;  // per fit: replay + final sweeps
  double mean_wall_s = 0.0;
  bench::SeedScatter scatter;
  double time_to_400_s = 0.0, time_to_400_lo_s = 0.0, time_to_400_hi_s = 0.0;
  std::vector<double> one_more_truck_s;  // one absorb per fit
  double one_more_mean_s = 0.0, one_more_max_s = 0.0;
  std::array<double, fleet::kHyperCount> mean{};  // over seeds of the posterior mean
};

struct McmcResult {
  int iterations = 0, burn_in = 0;
  double wall_s = 0.0, init_s = 0.0, per_sweep_s = 0.0;
  bool reached = false;
  int kept_sweeps_to_400 = 0;
  double time_to_400_s = std::numeric_limits<double>::quiet_NaN();
  std::array<double, fleet::kHyperCount> ess_at_400{}, ess_full{};
  int worst_full = 0;
  double min_ess_full = 0.0;
  double extrapolated_sweeps = std::numeric_limits<double>::quiet_NaN();
  double extrapolated_time_s = std::numeric_limits<double>::quiet_NaN();
  std::array<double, fleet::kHyperCount> mean{}, sd{};
  std::vector<std::pair<int, double>> min_ess_trace;  // (kept sweeps, min ESS) every 500
};

struct NResult {
  int trucks = 0;
  double load_before = 0.0, load_after = 0.0;
  std::string started, finished;
  SmcResult smc;
  McmcResult mcmc;
  double ratio = 0.0;               // MCMC time to 400 / SMC time to 400
  double ratio_lo = 0.0, ratio_hi = 0.0;  // from the SMC ESS interval
  double one_more_ratio = 0.0;      // MCMC time to 400 / one absorb
};

SmcResult run_smc(const site::Site& site, const fleet::SimulatedLog& log, const records::WimRecord& extra,
                  int seeds) {
  SmcResult r;
  r.seeds = seeds;
  std::vector<bench::RunSummary> runs;
  for (int s = 0; s < seeds; ++s) {
    fleet::MarginalSmc::Options o;
    o.sampler.particles = 1024;
    o.sampler.threads = 2;
    o.sampler.seed = static_cast<std::uint64_t>(100 + s);
    fleet::MarginalSmc smc(site, o);
    const auto t0 = clock_type::now();
    for (const auto& rec : log.records) smc.absorb(rec);
    smc.rejuvenate(o.sampler.schedule.final_sweeps);
    const double wall = seconds_since(t0);
    r.wall_s.push_back(wall);
    const fleet::PosteriorCloud c = smc.cloud();
    bench::RunSummary summary(fleet::kHyperCount);
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const Eigen::ArrayXd x = c.theta.row(h).transpose().array();
      const double mean = (x * c.weights).sum();
      summary[static_cast<std::size_t>(h)].mean = mean;
      summary[static_cast<std::size_t>(h)].sd = std::sqrt((c.weights * (x - mean).square()).sum());
      r.mean[static_cast<std::size_t>(h)] += mean / seeds;
    }
    runs.push_back(summary);
    const auto t1 = clock_type::now();
    smc.absorb(extra);
    r.one_more_truck_s.push_back(seconds_since(t1));
    std::cerr << "  SMC seed " << 100 + s << ": fit " << fmt(wall, 2) << " s, one more truck "
              << fmt(1e3 * r.one_more_truck_s.back(), 1) << " ms\n";
  }
  for (double w : r.wall_s) r.mean_wall_s += w / seeds;
  for (double w : r.one_more_truck_s) {
    r.one_more_mean_s += w / seeds;
    r.one_more_max_s = std::max(r.one_more_max_s, w);
  }
  r.scatter = bench::seed_scatter(runs);
  r.time_to_400_s = r.mean_wall_s * kTargetEss / r.scatter.min_ess;
  r.time_to_400_lo_s = r.mean_wall_s * kTargetEss / r.scatter.min_ess_hi90;  // more ESS, less time
  r.time_to_400_hi_s = r.mean_wall_s * kTargetEss / r.scatter.min_ess_lo90;
  return r;
}

McmcResult run_mcmc(const site::Site& site, const fleet::SimulatedLog& log, int iterations, int burn_in) {
  McmcResult r;
  fleet::BatchMcmcOptions o;
  o.iterations = iterations;
  o.burn_in = burn_in;
  o.threads = 2;
  o.progress_every = 5000;
  o.progress = [](const fleet::BatchMcmcProgress& p) {
    std::cerr << "  MCMC sweep " << p.iteration << "/" << p.iterations << " " << fmt(p.seconds, 1) << " s\n";
  };
  const fleet::BatchMcmcResult res = fleet::run_batch_mcmc(site, log.records, o);
  r.iterations = res.iterations;
  r.burn_in = res.burn_in;
  r.wall_s = res.wall_seconds;
  r.init_s = res.init_seconds;
  r.per_sweep_s = (res.wall_seconds - res.init_seconds) / res.iterations;
  const Eigen::Index kept = res.theta_draws.rows();
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const Eigen::VectorXd x = res.theta_draws.col(h);
    const double m = x.mean();
    r.mean[static_cast<std::size_t>(h)] = m;
    r.sd[static_cast<std::size_t>(h)] = std::sqrt((x.array() - m).square().sum() / static_cast<double>(kept - 1));
  }
  auto min_ess = [&](Eigen::Index len, std::array<double, fleet::kHyperCount>* per, int* worst) {
    double lo = std::numeric_limits<double>::infinity();
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const double e = chain_effective_sample_size(res.theta_draws.col(h).head(len));
      if (per) (*per)[static_cast<std::size_t>(h)] = e;
      if (!(e >= lo)) {  // NaN counts as the worst
        lo = std::isnan(e) ? 0.0 : e;
        if (worst) *worst = h;
      }
    }
    return lo;
  };
  for (Eigen::Index len = kCheckEvery; len <= kept; len += kCheckEvery) {
    std::array<double, fleet::kHyperCount> per{};
    const double e = min_ess(len, &per, nullptr);
    r.min_ess_trace.emplace_back(static_cast<int>(len), e);
    if (!r.reached && e >= kTargetEss) {
      r.reached = true;
      r.kept_sweeps_to_400 = static_cast<int>(len);
      r.ess_at_400 = per;
      r.time_to_400_s = r.init_s + (burn_in + static_cast<double>(len)) * r.per_sweep_s;
    }
  }
  r.min_ess_full = min_ess(kept, &r.ess_full, &r.worst_full);
  if (!r.reached && r.min_ess_full > 0.0) {
    r.extrapolated_sweeps = static_cast<double>(kept) * kTargetEss / r.min_ess_full;
    r.extrapolated_time_s = r.init_s + (burn_in + r.extrapolated_sweeps) * r.per_sweep_s;
  }
  return r;
}

nlohmann::json hyper_json(const std::array<double, fleet::kHyperCount>& v) {
  nlohmann::json j = nlohmann::json::object();
  for (int h = 0; h < fleet::kHyperCount; ++h) j[std::string(fleet::kHyperNames[h])] = num(v[static_cast<std::size_t>(h)]);
  return j;
}

void write_results(const std::vector<NResult>& results, const std::vector<int>& requested, int seeds,
                   const std::string& commit, long nproc, const std::string& started, const std::string& json_path,
                   const std::string& md_path) {
  nlohmann::json j;
  j["benchmark"] = "ratio";
  j["started_utc"] = started;
  j["written_utc"] = utc_now();
  j["commit"] = commit;
  j["nproc"] = nproc;
  j["trucks_requested"] = requested;
  j["complete"] = results.size() == requested.size();
  j["settings"] = {{"fleet", "Table 1 (FleetDistribution defaults)"},
                   {"road", "AS1"},
                   {"sigma_if", 0.02},
                   {"data_seed", 1},
                   {"smc", {{"particles", 1024}, {"threads", 2}, {"seeds", seeds}, {"first_seed", 100},
                            {"final_sweeps", fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps}, {"options", "default"}}},
                   {"mcmc", {{"threads", 2}, {"seed", 1}, {"options", "default (interweave K_t/sigma_kt, best-fit start)"},
                             {"ess_check_every_sweeps", kCheckEvery}}},
                   {"target_ess", kTargetEss},
                   {"smc_time_to_400", "mean wall per fit x 400 / smallest equivalent ESS"},
                   {"mcmc_time_to_400", "init_seconds + (burn_in + kept sweeps to ESS 400) x (wall - init) / iterations"},
                   {"one_more_truck", "one absorb() of a fresh simulated truck (fleet draw and noise seed 1000 + N) "
                                      "into each SMC fit after its final sweeps"}};
  nlohmann::json per_n = nlohmann::json::array();
  for (const auto& r : results) {
    const auto& s = r.smc;
    const auto& m = r.mcmc;
    nlohmann::json e;
    e["trucks"] = r.trucks;
    e["started_utc"] = r.started;
    e["finished_utc"] = r.finished;
    e["load_average_1min"] = {{"before", r.load_before}, {"after", r.load_after}};
    e["smc"] = {{"wall_per_fit_s", s.wall_s},
                {"mean_wall_per_fit_s", s.mean_wall_s},
                {"equivalent_ess", hyper_json(s.scatter.equivalent_ess)},
                {"posterior_sd", hyper_json(s.scatter.posterior_sd)},
                {"seed_scatter_sd", hyper_json(s.scatter.scatter)},
                {"posterior_mean", hyper_json(s.mean)},
                {"min_equivalent_ess", num(s.scatter.min_ess)},
                {"min_equivalent_ess_parameter", std::string(fleet::kHyperNames[s.scatter.worst])},
                {"min_equivalent_ess_90", {num(s.scatter.min_ess_lo90), num(s.scatter.min_ess_hi90)}},
                {"time_to_ess_400_s", num(s.time_to_400_s)},
                {"time_to_ess_400_90_s", {num(s.time_to_400_lo_s), num(s.time_to_400_hi_s)}},
                {"one_more_truck_s", s.one_more_truck_s},
                {"one_more_truck_mean_s", s.one_more_mean_s},
                {"one_more_truck_max_s", s.one_more_max_s}};
    nlohmann::json trace = nlohmann::json::array();
    for (const auto& [len, ess] : m.min_ess_trace) trace.push_back({len, num(ess)});
    e["mcmc"] = {{"iterations", m.iterations},
                 {"burn_in", m.burn_in},
                 {"wall_s", m.wall_s},
                 {"init_s", m.init_s},
                 {"per_sweep_s", m.per_sweep_s},
                 {"reached_ess_400", m.reached},
                 {"kept_sweeps_to_ess_400", m.reached ? nlohmann::json(m.kept_sweeps_to_400) : nlohmann::json(nullptr)},
                 {"sweeps_to_ess_400_incl_burn_in",
                  m.reached ? nlohmann::json(m.burn_in + m.kept_sweeps_to_400) : nlohmann::json(nullptr)},
                 {"time_to_ess_400_s", num(m.time_to_400_s)},
                 {"ess_at_400_prefix", m.reached ? hyper_json(m.ess_at_400) : nlohmann::json(nullptr)},
                 {"ess_full_chain", hyper_json(m.ess_full)},
                 {"min_ess_full_chain", num(m.min_ess_full)},
                 {"min_ess_full_chain_parameter", std::string(fleet::kHyperNames[m.worst_full])},
                 {"extrapolated_kept_sweeps_to_400", num(m.extrapolated_sweeps)},
                 {"extrapolated_time_to_400_s", num(m.extrapolated_time_s)},
                 {"posterior_mean", hyper_json(m.mean)},
                 {"posterior_sd", hyper_json(m.sd)},
                 {"min_ess_every_500_kept_sweeps", trace}};
    e["ratio_mcmc_over_smc"] = num(r.ratio);
    e["ratio_mcmc_over_smc_90"] = {num(r.ratio_lo), num(r.ratio_hi)};
    e["ratio_mcmc_to_400_over_one_more_truck"] = num(r.one_more_ratio);
    e["target_ratio"] = r.trucks >= 10000 ? nlohmann::json(10.0) : (r.trucks <= 100 ? nlohmann::json(1.0) : nlohmann::json(nullptr));
    per_n.push_back(e);
  }
  j["results"] = per_n;
  j["targets"] = "issue 14 item 6: MCMC/SMC time to ESS 400 >= 1x at N = 100, >= 10x at N = 10,000";
  if (!json_path.empty()) {
    std::ofstream f(json_path);
    f << j.dump(2) << "\n";
  }
  if (md_path.empty()) return;
  std::ofstream f(md_path);
  f << "# Ratio benchmark: SMC vs batch MCMC, wall time to ESS 400 on all 7 hyperparameters"
    << (results.size() == requested.size() ? "" : " (PARTIAL)") << "\n\n";
  f << "Table 1 fleet, road AS1, sigma_IF 0.02, data seed 1. Commit " << commit << ", nproc " << nproc
    << ", started " << started << ", written " << utc_now() << ". The machine may be shared: see the load.\n\n";
  f << "- SMC: fleet::MarginalSmc, default options, 1,024 particles, 2 threads, replay then rejuvenate("
    << fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps << "); " << seeds
    << " seeds (100, ...) on the same data. Equivalent ESS = (mean posterior sd)^2 / (variance of the "
    << seeds << " posterior means), the smallest over the 7. **SMC time to ESS 400 = mean wall per fit x 400 / "
       "smallest equivalent ESS.** With " << seeds << " seeds the equivalent ESS carries a chi-square("
    << seeds - 1 << ") factor: 90 % interval shown.\n";
  f << "- MCMC: fleet::run_batch_mcmc, default options (interweaving on, best-fit start), 2 threads, seed 1; one "
       "long chain; the first prefix of the kept chain (checked every "
    << kCheckEvery << " sweeps) whose smallest Geyer ESS over the 7 reaches 400. **Time = init + (burn-in + kept "
       "sweeps) x (wall - init) / iterations.**\n";
  f << "- One more truck: one absorb() of a fresh simulated truck into each SMC fit after its final sweeps (mean "
       "over the fits), against re-running the MCMC to ESS 400.\n\n";
  f << "| N | SMC wall/fit s | smallest equiv. ESS (param) [90 %] | SMC time to 400 s [90 %] | MCMC time to 400 s "
       "(sweeps incl. burn-in) | ratio MCMC/SMC [90 %] | target | one more truck (SMC) s | MCMC/one truck | "
       "load 1-min before/after |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : results) {
    const auto& s = r.smc;
    const auto& m = r.mcmc;
    std::string mc = m.reached ? fmt(m.time_to_400_s, 1) + " (" + std::to_string(m.burn_in + m.kept_sweeps_to_400) + ")"
                               : "not reached in " + std::to_string(m.iterations) + " (extrap. " +
                                     fmt(m.extrapolated_time_s, 1) + ")";
    f << "| " << r.trucks << " | " << fmt(s.mean_wall_s, 2) << " | " << fmt(s.scatter.min_ess, 0) << " ("
      << fleet::kHyperNames[s.scatter.worst] << ") [" << fmt(s.scatter.min_ess_lo90, 0) << ", "
      << fmt(s.scatter.min_ess_hi90, 0) << "] | " << fmt(s.time_to_400_s, 2) << " [" << fmt(s.time_to_400_lo_s, 2)
      << ", " << fmt(s.time_to_400_hi_s, 2) << "] | " << mc << " | " << fmt(r.ratio, 2) << " [" << fmt(r.ratio_lo, 2)
      << ", " << fmt(r.ratio_hi, 2) << "]" << (m.reached ? "" : " (extrap.)") << " | "
      << (r.trucks <= 100 ? ">= 1" : (r.trucks >= 10000 ? ">= 10" : "")) << " | " << fmt(s.one_more_mean_s, 4)
      << " (max " << fmt(s.one_more_max_s, 4) << ") | " << fmt(r.one_more_ratio, 0) << " | " << fmt(r.load_before, 2)
      << " / " << fmt(r.load_after, 2) << " |\n";
  }
  f << "\nTargets (issue 14 item 6): ratio >= 1 at N = 100, >= 10 at N = 10,000.\n";
  for (const auto& r : results) {
    const auto& s = r.smc;
    const auto& m = r.mcmc;
    f << "\n## N = " << r.trucks << "\n\n";
    f << "SMC wall per fit (s):";
    for (double w : s.wall_s) f << " " << fmt(w, 2);
    f << ". MCMC: " << m.iterations << " sweeps (burn-in " << m.burn_in << "), wall " << fmt(m.wall_s, 1)
      << " s, init " << fmt(m.init_s, 2) << " s, " << fmt(1e3 * m.per_sweep_s, 3) << " ms/sweep.\n\n";
    f << "| parameter | SMC equiv. ESS | SMC posterior mean | MCMC ESS at the 400 prefix | MCMC ESS full chain | "
         "MCMC posterior mean | MCMC posterior sd | SMC posterior sd |\n|---|---|---|---|---|---|---|---|\n";
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const auto H = static_cast<std::size_t>(h);
      f << "| " << fleet::kHyperNames[h] << " | " << fmt(s.scatter.equivalent_ess[H], 0) << " | "
        << std::setprecision(6) << s.mean[H] << " | " << (m.reached ? fmt(m.ess_at_400[H], 0) : "n/a") << " | "
        << fmt(m.ess_full[H], 0) << " | " << std::setprecision(6) << m.mean[H] << " | " << m.sd[H] << " | "
        << s.scatter.posterior_sd[H] << " |\n";
    }
  }
}

std::vector<int> parse_list(const std::string& s) {
  std::vector<int> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(std::stoi(item));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> trucks;
  int seeds = 8, mcmc_iterations = 0, mcmc_burn_in = 0;
  std::string json_path, md_path, commit;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--trucks") {
      for (int n : parse_list(next())) trucks.push_back(n);
    } else if (a == "--seeds") {
      seeds = std::stoi(next());
    } else if (a == "--json") {
      json_path = next();
    } else if (a == "--markdown") {
      md_path = next();
    } else if (a == "--mcmc-iterations") {
      mcmc_iterations = std::stoi(next());
    } else if (a == "--mcmc-burn-in") {
      mcmc_burn_in = std::stoi(next());
    } else if (a == "--commit") {
      commit = next();
    } else {
      std::cerr << "usage: ratio_benchmark [--trucks 100,1000] [--seeds 8] [--json FILE] [--markdown FILE]\n"
                   "                       [--mcmc-iterations I --mcmc-burn-in B] [--commit HASH]\n";
      return 2;
    }
  }
  if (trucks.empty()) trucks = {100, 1000};
  if (seeds < 2) {
    std::cerr << "ratio_benchmark: --seeds must be at least 2\n";
    return 2;
  }
  if (commit.empty()) commit = run_command("git rev-parse --short HEAD 2>/dev/null");
  const long nproc = sysconf(_SC_NPROCESSORS_ONLN);
  const std::string started = utc_now();

  const site::Site site(road::preset_surface("AS1"), site::SiteOptions{});
  std::vector<NResult> results;
  for (int N : trucks) {
    NResult r;
    r.trucks = N;
    r.started = utc_now();
    r.load_before = load_average_1min();
    const auto fleet_trucks =
        fleet::draw_fleet(fleet::FleetDistribution{}, N, site.lateral_min_m(), site.lateral_max_m(), 1);
    const fleet::SimulatedLog log = fleet::simulate_log(site, fleet_trucks, 0.02, 1);
    // The fresh truck: its own fleet draw and noise seed, and an id of its own.
    auto extra_trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 1, site.lateral_min_m(), site.lateral_max_m(),
                                          static_cast<std::uint64_t>(1000 + N));
    extra_trucks[0].truck_id = "EXTRA";
    const fleet::SimulatedLog extra_log = fleet::simulate_log(site, extra_trucks, 0.02, static_cast<std::uint64_t>(1000 + N));
    const records::WimRecord extra = extra_log.records.at(0);

    std::cerr << "N=" << N << ": SMC, " << seeds << " seeds (load " << fmt(r.load_before, 2) << ")\n";
    r.smc = run_smc(site, log, extra, seeds);
    const int it = mcmc_iterations > 0 ? mcmc_iterations : (N <= 100 ? 40000 : 20000);
    const int bi = mcmc_burn_in > 0 ? mcmc_burn_in : 5000;
    std::cerr << "N=" << N << ": MCMC, " << it << " sweeps, burn-in " << bi << "\n";
    r.mcmc = run_mcmc(site, log, it, bi);
    r.load_after = load_average_1min();
    r.finished = utc_now();
    const double mcmc_t = r.mcmc.reached ? r.mcmc.time_to_400_s : r.mcmc.extrapolated_time_s;
    r.ratio = mcmc_t / r.smc.time_to_400_s;
    r.ratio_lo = mcmc_t / r.smc.time_to_400_hi_s;
    r.ratio_hi = mcmc_t / r.smc.time_to_400_lo_s;
    r.one_more_ratio = mcmc_t / r.smc.one_more_mean_s;
    results.push_back(r);

    const auto& s = r.smc;
    const auto& m = r.mcmc;
    std::cout << "N=" << N << " (load 1-min " << fmt(r.load_before, 2) << " -> " << fmt(r.load_after, 2) << ")\n"
              << "  SMC: mean wall per fit " << fmt(s.mean_wall_s, 2) << " s (replay + " 
              << fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps << " final sweeps); smallest equivalent ESS "
              << fmt(s.scatter.min_ess, 0) << " (" << fleet::kHyperNames[s.scatter.worst] << "), 90 % ["
              << fmt(s.scatter.min_ess_lo90, 0) << ", " << fmt(s.scatter.min_ess_hi90, 0) << "]\n"
              << "       time to ESS 400 = mean wall x 400 / smallest equivalent ESS = " << fmt(s.time_to_400_s, 2)
              << " s, 90 % [" << fmt(s.time_to_400_lo_s, 2) << ", " << fmt(s.time_to_400_hi_s, 2) << "]\n";
    if (m.reached)
      std::cout << "  MCMC: ESS 400 on all 7 after " << m.kept_sweeps_to_400 << " kept sweeps (+" << m.burn_in
                << " burn-in): time to ESS 400 " << fmt(m.time_to_400_s, 2) << " s (init " << fmt(m.init_s, 2)
                << " s, " << fmt(1e3 * m.per_sweep_s, 3) << " ms/sweep, whole chain " << fmt(m.wall_s, 1) << " s)\n";
    else
      std::cout << "  MCMC: ESS 400 NOT reached in " << m.iterations - m.burn_in << " kept sweeps (min ESS "
                << fmt(m.min_ess_full, 0) << ", " << fleet::kHyperNames[m.worst_full] << "); EXTRAPOLATED "
                << fmt(m.extrapolated_sweeps, 0) << " kept sweeps, " << fmt(m.extrapolated_time_s, 2) << " s\n";
    std::cout << "  full-chain min ESS " << fmt(m.min_ess_full, 0) << " (" << fleet::kHyperNames[m.worst_full]
              << ")\n  ratio MCMC/SMC " << fmt(r.ratio, 2) << " [" << fmt(r.ratio_lo, 2) << ", "
              << fmt(r.ratio_hi, 2) << "]" << (m.reached ? "" : " (extrapolated)") << "\n"
              << "  one more truck (SMC absorb) mean " << fmt(1e3 * s.one_more_mean_s, 2) << " ms (max "
              << fmt(1e3 * s.one_more_max_s, 2) << " ms); MCMC re-run to 400 / one absorb = "
              << fmt(r.one_more_ratio, 0) << "\n"
              << std::flush;
    write_results(results, trucks, seeds, commit, nproc, started, json_path, md_path);
  }
  return 0;
}
