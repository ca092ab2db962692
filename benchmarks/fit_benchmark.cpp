// End-to-end fit benchmark (the issue "SMC vs MCMC on one fleet"): one simulated data set, a
// 100-truck AS1 fleet drawn from Table 1 (docs/model.md) with sigma_IF = 0.02, fitted twice:
//
//   SMC  - FleetSmc replaying the log truck by truck (default options except particles, threads,
//          seed): total wall time, per-truck update latency (steady_clock around absorb()),
//          integrator passes, passes per second;
//   MCMC - run_batch_mcmc on the same records (burn-in 5000 sweeps as `fit --method mcmc`, thin 1;
//          50000 sweeps in all, enough to reach ESS 400 on this case): the wall time
//          at which the Geyer ESS of every one of the 7 hyperparameters first reaches 400,
//          found on prefixes of the kept chain;
//
// then the posteriors side by side against each other and the truth, and the SMC replayed with
// --accuracy-seeds more seeds on the same data: the scatter of its posterior means gives its
// equivalent ESS (seed_scatter.hpp), so that the speed-up is also stated at equal accuracy. As
// `ssrfleet fit` does, every replay ends with --final-sweeps rejuvenation sweeps
// (FleetSmc::rejuvenate); the equivalent ESS is measured both at the end of the replay and after
// them, side by side, and the equal-accuracy time counts the sweeps.
//
// Integrator share: the library does not time its integrator calls, so the share is an ESTIMATE:
// the cost of one pass of Site::impact_factors is calibrated in this run (single thread, batches
// of 512 realistic trucks, half the repetitions before and half after the SMC replay), and
//     share = passes x cost_per_pass / (SMC wall time x threads used),
// i.e. the CPU-time budget is wall time times threads. Contention, idle threads and the serial
// parts all count against the share; a pass counted by the target but skipped as non-physical
// (k <= 0, kt <= 0, z off the road) counts as a full pass (a small over-estimate).
//
//   fit_benchmark [--trucks 100] [--particles 1024] [--threads 0=all] [--seed 1]
//                 [--mcmc-iterations 50000] [--mcmc-burn-in 5000] [--accuracy-seeds 7] [--final-sweeps 50]
//                 [--json FILE] [--markdown FILE]
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <time.h>

#include <nlohmann/json.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet/fleet_smc.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "seed_scatter.hpp"
#include "site/road_source.hpp"
#include "site/site.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kNoiseSd = 0.02;
constexpr double kEssTarget = 400.0;
constexpr int kEssPrefixStep = 500;      // kept sweeps between ESS evaluations
constexpr int kCalibrationBatch = 512;   // trucks per Site::impact_factors call
constexpr int kCalibrationReps = 10;     // half before, half after the SMC replay
// Table 1 truth in Hyper order (fleet_model.hpp).
constexpr std::array<double, fleet::kHyperCount> kTruth = {500e3, 50e3, 1950e3, 195e3, 1.5, 0.5, kNoiseSd};

// Targets of the issue.
constexpr double kTargetReplayS = 20.0;
constexpr double kTargetP50S = 0.2;
constexpr double kTargetShare = 0.70;
constexpr double kTargetSpeedup = 10.0;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Linear-interpolation quantile (type 7) of unweighted values.
double quantile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double h = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double median(const std::vector<double>& v) { return quantile(v, 0.5); }

// CPU time of this process (all threads), to tell contention and serial time from integrator time.
double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// 1-minute load average (other users of the machine show up here).
double load_average() {
  std::ifstream in("/proc/loadavg");
  double one = std::numeric_limits<double>::quiet_NaN();
  in >> one;
  return one;
}

const char* isa_name() {
#if defined(__AVX512F__)
  return "avx512";
#elif defined(__AVX2__)
  return "avx2";
#elif defined(__AVX__)
  return "avx";
#elif defined(__SSE2__)
  return "sse2";
#else
  return "generic";
#endif
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        std::string s = line.substr(colon + 1);
        s.erase(0, s.find_first_not_of(" \t"));
        return s;
      }
    }
  }
  return "unknown";
}

// Per-pass cost of Site::impact_factors on batches of `batch` trucks: the records' speeds and
// masses with Table 1 latents (z truncated to the surface), one call per repetition.
struct Calibration {
  site::TruckBatch batch;
  Eigen::ArrayXXd out;
  std::vector<double> us_per_pass;  // one entry per repetition
  double sink = 0.0;

  Calibration(const site::Site& site, const std::vector<records::WimRecord>& records, int trucks, std::uint64_t seed) {
    std::mt19937_64 engine(seed ^ 0x9e3779b97f4a7c15ULL);
    std::normal_distribution<double> normal;
    batch.resize(trucks);
    for (int i = 0; i < trucks; ++i) {
      const auto& r = records[static_cast<std::size_t>(i) % records.size()];
      batch.speed_mps[i] = r.speed_mps;
      batch.sprung_mass_kg[i] = r.sprung_mass_kg;
      batch.stiffness_npm[i] = kTruth[fleet::kK] + kTruth[fleet::kSigmaK] * normal(engine);
      batch.tyre_stiffness_npm[i] = kTruth[fleet::kKt] + kTruth[fleet::kSigmaKt] * normal(engine);
      double z;
      do {
        z = kTruth[fleet::kZ] + kTruth[fleet::kSigmaZ] * normal(engine);
      } while (z < site.lateral_min_m() || z > site.lateral_max_m());
      batch.lateral_m[i] = z;
    }
    out.resize(site.sensors(), trucks);
  }

  void run(const site::Site& site, int reps) {
    for (int r = 0; r < reps; ++r) {
      const auto t0 = Clock::now();
      site.impact_factors(batch, out);
      us_per_pass.push_back(1e6 * seconds_since(t0) / static_cast<double>(batch.size()));
      sink += out(0, 0);
    }
  }
};

struct EssPoint {
  int kept = 0;  // kept sweeps in the prefix
  double time_s = 0.0;
  std::array<double, fleet::kHyperCount> ess{};
  double min_ess = 0.0;
};

std::string fmt(const char* f, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, x);
  return buf;
}

std::string status(bool met) { return met ? "met" : "MISSED"; }

nlohmann::json summary_json(const fleet::ParameterSummary& s) {
  return {{"mean", s.mean}, {"sd", s.sd}, {"q025", s.q025}, {"q975", s.q975}};
}

void usage() {
  std::cerr << "usage: fit_benchmark [--trucks 100] [--particles 1024] [--threads 0=all] [--seed 1]\n"
               "                     [--mcmc-iterations 50000] [--mcmc-burn-in 5000] [--accuracy-seeds 7] [--final-sweeps "
            << fleet::FleetSmc::Options{}.sampler.schedule.final_sweeps << "]\n"
               "                     [--json FILE] [--markdown FILE]\n";
}

}  // namespace

int main(int argc, char** argv) {
  int trucks = 100, particles = 1024, threads = 0, mcmc_iterations = 50000, accuracy_seeds = 7;
  int final_sweeps = fleet::FleetSmc::Options{}.sampler.schedule.final_sweeps;
  int burn_in = 5000;
  std::uint64_t seed = 1;
  std::string json_path, markdown_path;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const bool has_value = i + 1 < argc;
      if (a == "--trucks" && has_value) trucks = std::stoi(argv[++i]);
      else if (a == "--particles" && has_value) particles = std::stoi(argv[++i]);
      else if (a == "--threads" && has_value) threads = std::stoi(argv[++i]);
      else if (a == "--seed" && has_value) seed = std::stoull(argv[++i]);
      else if (a == "--mcmc-iterations" && has_value) mcmc_iterations = std::stoi(argv[++i]);
      else if (a == "--accuracy-seeds" && has_value) accuracy_seeds = std::stoi(argv[++i]);
      else if (a == "--mcmc-burn-in" && has_value) burn_in = std::stoi(argv[++i]);
      else if (a == "--final-sweeps" && has_value) final_sweeps = std::stoi(argv[++i]);
      else if (a == "--json" && has_value) json_path = argv[++i];
      else if (a == "--markdown" && has_value) markdown_path = argv[++i];
      else {
        usage();
        return 64;
      }
    }
  } catch (const std::exception&) {
    usage();
    return 64;
  }
  if (trucks < 2 || particles < 2 || threads < 0 || mcmc_iterations < 8 || burn_in < 0 ||
      burn_in > mcmc_iterations - kEssPrefixStep || accuracy_seeds < 0 || final_sweeps < 0) {
    std::cerr << "fit_benchmark: need trucks >= 2, particles >= 2, threads >= 0, mcmc-iterations >= 8, "
                 "0 <= mcmc-burn-in <= mcmc-iterations - "
              << kEssPrefixStep << ", accuracy-seeds >= 0, final-sweeps >= 0\n";
    return 64;
  }
  const int threads_used = threads > 0 ? threads : smc::TemperedSampler::Options::default_threads();
  const unsigned hardware_threads = std::thread::hardware_concurrency();

  // ---- 1. Data, once --------------------------------------------------------------------------
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto fleet_trucks =
      fleet::draw_fleet(fleet::FleetDistribution{}, trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  const fleet::SimulatedLog log = fleet::simulate_log(site, fleet_trucks, kNoiseSd, seed);
  const auto& records = log.records;
  std::printf("fit benchmark: %d-truck AS1 fleet (Table 1), sigma_IF = %.3f, seed %llu, %d sensors, %d lift-offs\n",
              trucks, kNoiseSd, static_cast<unsigned long long>(seed), site.sensors(), log.lift_offs);
  std::printf("machine: %u hardware threads, %s, ISA %s; SMC: %d particles, %d threads; MCMC: %d sweeps "
              "(burn-in %d), 1 thread\n",
              hardware_threads, cpu_model().c_str(), isa_name(), particles, threads_used, mcmc_iterations, burn_in);
  std::fflush(stdout);

  // ---- 3a. Integrator calibration, first half ---------------------------------------------------
  Calibration calibration(site, records, kCalibrationBatch, seed);
  calibration.run(site, 1);  // warm-up, discarded
  calibration.us_per_pass.clear();
  calibration.run(site, kCalibrationReps / 2);

  // ---- 2. SMC replay ------------------------------------------------------------------------------
  fleet::FleetSmc::Options smc_options;
  smc_options.sampler.particles = particles;
  smc_options.sampler.threads = threads_used;
  smc_options.sampler.seed = seed;
  std::vector<double> latency_s;
  latency_s.reserve(records.size());
  int tempering_steps = 0, mh_sweeps = 0, resamplings = 0;
  double stage_wall_s = 0.0, newest_acceptance_sum = 0.0;
  int capped_steps = 0;
  const double load_before = load_average();
  const double smc_cpu0 = process_cpu_s();
  const auto smc_t0 = Clock::now();
  fleet::FleetSmc smc(site, smc_options);
  for (const auto& record : records) {
    const auto t0 = Clock::now();
    const smc::StageSummary& stage = smc.absorb(record);
    latency_s.push_back(seconds_since(t0));
    tempering_steps += static_cast<int>(stage.steps.size());
    for (const auto& step : stage.steps) {
      mh_sweeps += step.mh.sweeps;
      capped_steps += step.mh.sweeps >= smc_options.sampler.schedule.max_sweeps ? 1 : 0;
      if (!step.mh.acceptance.empty()) newest_acceptance_sum += step.mh.acceptance.front();
    }
    resamplings += stage.resamplings();
    stage_wall_s += stage.wall_time_s;
  }
  const double smc_wall_s = seconds_since(smc_t0);
  const double smc_cpu_s = process_cpu_s() - smc_cpu0;
  const double load_after_smc = load_average();
  const double newest_acceptance = tempering_steps > 0 ? newest_acceptance_sum / tempering_steps : 0.0;
  const long long smc_passes = smc.target().integrator_passes();
  const auto replay_summary = fleet::summarise_weighted(smc.cloud().theta, smc.cloud().weights);
  // The offline fit's last step (not part of the replay's targets, counted in the equal-accuracy time).
  const auto final_t0 = Clock::now();
  smc.rejuvenate(final_sweeps);
  const double final_s = seconds_since(final_t0);
  const long long final_passes = smc.target().integrator_passes() - smc_passes;
  const double final_acceptance = smc.target().older_acceptance();
  const fleet::PosteriorCloud cloud = smc.cloud();
  double latency_total = 0.0;
  for (double t : latency_s) latency_total += t;
  const double p50 = quantile(latency_s, 0.5), p99 = quantile(latency_s, 0.99);
  const double latency_mean = latency_total / static_cast<double>(latency_s.size());
  const double latency_max = *std::max_element(latency_s.begin(), latency_s.end());

  // ---- 3b. Integrator calibration, second half; the share -------------------------------------
  const std::vector<double> calibration_before = calibration.us_per_pass;
  calibration.run(site, kCalibrationReps - kCalibrationReps / 2);
  const std::vector<double> calibration_after(calibration.us_per_pass.begin() + kCalibrationReps / 2,
                                              calibration.us_per_pass.end());
  const double us_per_pass = median(calibration.us_per_pass);
  const double integrator_cpu_s = static_cast<double>(smc_passes) * us_per_pass * 1e-6;
  const double share = integrator_cpu_s / (smc_wall_s * threads_used);
  // Diagnostics beside the headline share: how much CPU the replay actually got, and the
  // integrator's share of that (contention and idle threads drop out of this one).
  const double cores_used = smc_cpu_s / smc_wall_s;
  const double share_of_process_cpu = integrator_cpu_s / smc_cpu_s;
  const double passes_per_s = static_cast<double>(smc_passes) / smc_wall_s;
  std::printf("SMC done: %.2f s; MCMC running ...\n", smc_wall_s);
  std::fflush(stdout);

  // ---- 4. MCMC baseline ---------------------------------------------------------------------------
  fleet::BatchMcmcOptions mcmc_options;
  mcmc_options.iterations = mcmc_iterations;
  mcmc_options.burn_in = burn_in;
  mcmc_options.thin = 1;
  mcmc_options.seed = seed;
  const double mcmc_cpu0 = process_cpu_s();
  const fleet::BatchMcmcResult mcmc = fleet::run_batch_mcmc(site, records, mcmc_options);
  const double mcmc_cpu_s = process_cpu_s() - mcmc_cpu0;
  const double load_after_mcmc = load_average();
  const Eigen::Index kept = mcmc.theta_draws.rows();
  // Constant time per sweep after the initial grid search.
  const double sweep_s = (mcmc.wall_seconds - mcmc.init_seconds) / static_cast<double>(mcmc.iterations);
  const auto time_at = [&](double kept_sweeps) {
    return mcmc.init_seconds + (static_cast<double>(mcmc.burn_in) + kept_sweeps) * sweep_s;
  };
  std::vector<EssPoint> ess_trace;
  for (Eigen::Index m = kEssPrefixStep;; m += kEssPrefixStep) {
    m = std::min(m, kept);
    EssPoint p;
    p.kept = static_cast<int>(m);
    p.time_s = time_at(static_cast<double>(m));
    p.min_ess = std::numeric_limits<double>::infinity();
    for (int j = 0; j < fleet::kHyperCount; ++j) {
      const Eigen::VectorXd chain = mcmc.theta_draws.col(j).head(m);
      p.ess[static_cast<std::size_t>(j)] = chain_effective_sample_size(chain);
      // NaN (constant chain) counts as no information.
      const double e = std::isnan(p.ess[static_cast<std::size_t>(j)]) ? 0.0 : p.ess[static_cast<std::size_t>(j)];
      p.min_ess = std::min(p.min_ess, e);
    }
    ess_trace.push_back(p);
    if (m == kept) break;
  }
  std::optional<double> kept_to_target;  // interpolated kept sweeps at which min ESS first reaches 400
  for (std::size_t i = 0; i < ess_trace.size(); ++i) {
    if (ess_trace[i].min_ess < kEssTarget) continue;
    const double m1 = ess_trace[i].kept, e1 = ess_trace[i].min_ess;
    const double m0 = i == 0 ? 0.0 : ess_trace[i - 1].kept, e0 = i == 0 ? 0.0 : ess_trace[i - 1].min_ess;
    kept_to_target = e1 > e0 ? m0 + (kEssTarget - e0) / (e1 - e0) * (m1 - m0) : m1;
    break;
  }
  const std::optional<double> mcmc_time_to_target =
      kept_to_target ? std::optional<double>(time_at(*kept_to_target)) : std::nullopt;
  const EssPoint& ess_final = ess_trace.back();
  // If not reached: a labelled extrapolation assuming ESS grows linearly with kept sweeps (never
  // used for a target status).
  std::optional<double> mcmc_time_extrapolated;
  if (!mcmc_time_to_target && ess_final.min_ess > 0.0)
    mcmc_time_extrapolated = time_at(static_cast<double>(kept) * kEssTarget / ess_final.min_ess);

  // ---- 5. Accuracy --------------------------------------------------------------------------------
  const auto smc_summary = fleet::summarise_weighted(cloud.theta, cloud.weights);
  const auto mcmc_summary = fleet::summarize_draws(mcmc.theta_draws);

  // ---- 5b. The SMC's own Monte Carlo error: the same data, more seeds -----------------------------
  std::vector<bench::RunSummary> seed_runs{smc_summary}, seed_runs_replay{replay_summary};
  for (int r = 1; r <= accuracy_seeds; ++r) {
    std::printf("SMC replay with seed %llu (%d of %d, for the seed-to-seed scatter) ...\n",
                static_cast<unsigned long long>(seed + r), r, accuracy_seeds);
    std::fflush(stdout);
    fleet::FleetSmc::Options o = smc_options;
    o.sampler.seed = seed + static_cast<std::uint64_t>(r);
    fleet::FleetSmc again(site, o);
    for (const auto& record : records) again.absorb(record);
    seed_runs_replay.push_back(fleet::summarise_weighted(again.cloud().theta, again.cloud().weights));
    again.rejuvenate(final_sweeps);
    seed_runs.push_back(fleet::summarise_weighted(again.cloud().theta, again.cloud().weights));
  }
  const bench::SeedScatter scatter = bench::seed_scatter(seed_runs);
  const bench::SeedScatter scatter_replay = bench::seed_scatter(seed_runs_replay);
  const bool equal_accuracy = scatter.runs >= 2;
  // The SMC's error variance falls as 1/particles and its cost grows with them, so its time to
  // the MCMC's accuracy (ESS 400) is its wall time x 400 / its equivalent ESS; the fit's time is
  // the replay and the final sweeps.
  const double fit_s = smc_wall_s + final_s;
  const double smc_time_equal_accuracy = equal_accuracy ? fit_s * kEssTarget / scatter.min_ess : 0.0;
  const double replay_time_equal_accuracy = equal_accuracy ? smc_wall_s * kEssTarget / scatter_replay.min_ess : 0.0;

  // ---- 6. Speed-up and targets ----------------------------------------------------------------
  // If the MCMC never reached the ESS target, its whole run is a lower bound on its time to it.
  const double mcmc_time_or_bound = mcmc_time_to_target ? *mcmc_time_to_target : mcmc.wall_seconds;
  const double speedup = mcmc_time_or_bound / smc_wall_s;
  const double speedup_equal = equal_accuracy ? mcmc_time_or_bound / smc_time_equal_accuracy : 0.0;
  const double speedup_equal_replay = equal_accuracy ? mcmc_time_or_bound / replay_time_equal_accuracy : 0.0;
  // The target says "to the same accuracy": judged at equal accuracy when the seeds were run.
  const double speedup_judged = equal_accuracy ? speedup_equal : speedup;
  const bool comparable_setup = particles == 1024 && threads_used == 2 && trucks == 100;
  const bool replay_met = smc_wall_s <= kTargetReplayS, p50_met = p50 <= kTargetP50S, share_met = share >= kTargetShare;
  const bool speedup_met = speedup_judged >= kTargetSpeedup;  // a lower bound meets it too
  const std::string speedup_status =
      mcmc_time_to_target ? status(speedup_met) : (speedup_met ? "met (lower bound: MCMC never reached ESS 400)"
                                                               : "undetermined (MCMC never reached ESS 400)");
  const std::string speedup_basis = equal_accuracy ? "at equal accuracy (SMC time scaled to an equivalent ESS of 400)"
                                                   : "SMC at its particle count (no seed scatter measured)";

  // ---- Report -------------------------------------------------------------------------------------
  std::printf("\nSMC replay (%d trucks, %d particles, %d threads)\n", trucks, particles, threads_used);
  std::printf("  %-38s %12.3f s\n", "whole replay (wall)", smc_wall_s);
  std::printf("  %-38s %12.3f s   (sum of StageSummary::wall_time_s: %.3f s)\n", "sum of per-truck latencies",
              latency_total, stage_wall_s);
  std::printf("  %-38s %12.4f s\n", "per-truck latency p50", p50);
  std::printf("  %-38s %12.4f s\n", "per-truck latency p99", p99);
  std::printf("  %-38s %12.4f s   (max %.4f s, last truck %.4f s)\n", "per-truck latency mean", latency_mean,
              latency_max, latency_s.back());
  std::printf("  %-38s %12lld\n", "integrator passes", smc_passes);
  std::printf("  %-38s %12.0f   (%.0f per thread)\n", "passes per second (wall)", passes_per_s,
              passes_per_s / threads_used);
  std::printf("  %-38s %12d / %d / %d\n", "tempering steps / MH sweeps / resamplings", tempering_steps, mh_sweeps,
              resamplings);
  std::printf("  %-38s %12.1f %%   (max_steps %d; newest-truck block acceptance %.2f)\n",
              "steps whose MH sweeps hit max_steps", 100.0 * capped_steps / std::max(1, tempering_steps),
              smc_options.sampler.schedule.max_sweeps, newest_acceptance);
  std::printf("  %-38s %12.2f s   (%.2f cores busy on average; load average %.2f before, %.2f after)\n",
              "process CPU time during the replay", smc_cpu_s, cores_used, load_before, load_after_smc);
  std::printf("  %-38s %12.1f   (log evidence %.2f)\n", "final ESS", cloud.weight_ess, cloud.log_evidence);
  std::printf("  %-38s %12.3f s   (%d sweeps, %lld passes, acceptance of the last %.2f)\n", "final rejuvenation sweeps",
              final_s, final_sweeps, final_passes, final_acceptance);
  std::printf("integrator calibration: Site::impact_factors, %d trucks per call, 1 thread, %d reps (%d before, %d "
              "after the replay)\n",
              kCalibrationBatch, kCalibrationReps, kCalibrationReps / 2, kCalibrationReps - kCalibrationReps / 2);
  std::printf("  %-38s %12.3f us   (before %.3f, after %.3f)\n", "cost per pass (median)", us_per_pass,
              median(calibration_before), median(calibration_after));
  std::printf("  %-38s %12.1f %%   ESTIMATE = passes x calibrated cost / (wall x %d threads)\n",
              "integrator share of CPU budget", 100.0 * share, threads_used);
  std::printf("  %-38s %12.1f %%   (diagnostic: passes x calibrated cost / process CPU time)\n",
              "integrator share of CPU actually used", 100.0 * share_of_process_cpu);

  std::printf("\nMCMC baseline (%d sweeps, burn-in %d, thin 1, 1 thread)\n", mcmc.iterations, mcmc.burn_in);
  std::printf("  %-38s %12.3f s   (grid-search init %.3f s, %.3f ms per sweep)\n", "wall", mcmc.wall_seconds,
              mcmc.init_seconds, 1e3 * sweep_s);
  std::printf("  %-38s %12lld\n", "integrator passes", mcmc.integrator_passes);
  std::printf("  %-38s %12.2f s   (load average after %.2f)\n", "process CPU time", mcmc_cpu_s, load_after_mcmc);
  std::printf("  %-38s %12.2f / %.2f\n", "latent / (Z, sigma_z) acceptance", mcmc.latent_acceptance,
              mcmc.z_acceptance);
  std::printf("  ESS on prefixes of the kept chain (every %d sweeps):\n", kEssPrefixStep);
  std::printf("    %7s %9s", "kept", "time s");
  for (const auto& name : fleet::kHyperNames) std::printf(" %9s", std::string(name).c_str());
  std::printf(" %9s\n", "min");
  for (const auto& p : ess_trace) {
    std::printf("    %7d %9.2f", p.kept, p.time_s);
    for (double e : p.ess) std::printf(" %9.0f", e);
    std::printf(" %9.0f\n", p.min_ess);
  }
  if (mcmc_time_to_target)
    std::printf("  %-38s %12.3f s   (%.0f kept sweeps after a %d-sweep burn-in; interpolated)\n",
                "time to ESS >= 400 on all 7", *mcmc_time_to_target, *kept_to_target, mcmc.burn_in);
  else
  {
    std::printf("  %-38s %12s     (min ESS %.0f after all %lld kept sweeps)\n", "time to ESS >= 400 on all 7",
                "not reached", ess_final.min_ess, static_cast<long long>(kept));
    if (mcmc_time_extrapolated)
      std::printf("  %-38s %12.3f s   (EXTRAPOLATED, ESS linear in kept sweeps; not used for the target)\n",
                  "  extrapolated time to ESS 400", *mcmc_time_extrapolated);
  }

  std::printf("\nAccuracy: SMC (weighted particles) vs MCMC (kept draws); SMD = (mean_SMC - mean_MCMC) / sd_MCMC;\n"
              "dq = (q_SMC - q_MCMC) / MCMC 95%% width\n");
  std::printf("  %-9s %11s | %11s %10s %11s %11s | %11s %10s %11s %11s | %6s %6s %6s %6s\n", "param", "truth",
              "SMC mean", "sd", "q025", "q975", "MCMC mean", "sd", "q025", "q975", "SMD", "dq025", "dq975",
              "sd rat");
  nlohmann::json accuracy = nlohmann::json::array();
  double max_abs_smd = 0.0, max_abs_dq = 0.0;
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto& s = smc_summary[static_cast<std::size_t>(j)];
    const auto& m = mcmc_summary[static_cast<std::size_t>(j)];
    const double width = m.q975 - m.q025;
    const double smd = (s.mean - m.mean) / m.sd, dq025 = (s.q025 - m.q025) / width, dq975 = (s.q975 - m.q975) / width;
    const double sd_ratio = s.sd / m.sd;
    max_abs_smd = std::max(max_abs_smd, std::abs(smd));
    max_abs_dq = std::max({max_abs_dq, std::abs(dq025), std::abs(dq975)});
    const double truth = kTruth[static_cast<std::size_t>(j)];
    std::printf("  %-9s %11.4g | %11.4g %10.3g %11.4g %11.4g | %11.4g %10.3g %11.4g %11.4g | %6.2f %6.2f %6.2f %6.2f\n",
                std::string(fleet::kHyperNames[static_cast<std::size_t>(j)]).c_str(), truth, s.mean, s.sd, s.q025,
                s.q975, m.mean, m.sd, m.q025, m.q975, smd, dq025, dq975, sd_ratio);
    accuracy.push_back({{"parameter", std::string(fleet::kHyperNames[static_cast<std::size_t>(j)])},
                        {"truth", truth},
                        {"smc", summary_json(s)},
                        {"mcmc", summary_json(m)},
                        {"standardised_mean_difference", smd},
                        {"q025_difference_over_mcmc_width", dq025},
                        {"q975_difference_over_mcmc_width", dq975},
                        {"sd_ratio_smc_over_mcmc", sd_ratio},
                        {"truth_in_smc_95", truth >= s.q025 && truth <= s.q975},
                        {"truth_in_mcmc_95", truth >= m.q025 && truth <= m.q975},
                        {"mcmc_ess", ess_final.ess[static_cast<std::size_t>(j)]}});
  }
  std::printf("  max |SMD| %.2f, max |dq| %.2f\n", max_abs_smd, max_abs_dq);

  std::printf("\nSMC speed-up vs MCMC to ESS 400: %s%.3gx", mcmc_time_to_target ? "" : ">= ", speedup);
  if (mcmc_time_extrapolated)
    std::printf("   (extrapolated: %.3gx)", *mcmc_time_extrapolated / smc_wall_s);
  std::printf("\n");
  if (equal_accuracy) {
    std::printf("\nSMC seed-to-seed scatter (%d replays of the same data, seeds %llu-%llu):\n", scatter.runs,
                static_cast<unsigned long long>(seed), static_cast<unsigned long long>(seed + accuracy_seeds));
    std::printf("  %-9s %12s %12s %12s %12s\n", "param", "scatter", "post. sd", "scatter/sd", "equiv. ESS");
    for (int j = 0; j < fleet::kHyperCount; ++j) {
      const auto J = static_cast<std::size_t>(j);
      std::printf("  %-9s %12.4g %12.4g %12.3f %12.0f\n", std::string(fleet::kHyperNames[J]).c_str(), scatter.scatter[J],
                  scatter.posterior_sd[J], scatter.scatter[J] / scatter.posterior_sd[J], scatter.equivalent_ess[J]);
    }
    std::printf("  smallest equivalent ESS %.0f (%s; 90 %% interval %.0f-%.0f) after %d final sweeps\n", scatter.min_ess,
                std::string(fleet::kHyperNames[static_cast<std::size_t>(scatter.worst)]).c_str(), scatter.min_ess_lo90,
                scatter.min_ess_hi90, final_sweeps);
    std::printf("  at the end of the replay (no final sweeps): %.0f (%s; 90 %% interval %.0f-%.0f); per parameter:",
                scatter_replay.min_ess,
                std::string(fleet::kHyperNames[static_cast<std::size_t>(scatter_replay.worst)]).c_str(),
                scatter_replay.min_ess_lo90, scatter_replay.min_ess_hi90);
    for (double e : scatter_replay.equivalent_ess) std::printf(" %.0f", e);
    std::printf("\n  SMC time to an equivalent ESS of 400: %.2f s (replay and final sweeps); speed-up vs MCMC at equal "
                "accuracy: %s%.3gx (replay alone: %.2f s, %s%.3gx)\n",
                smc_time_equal_accuracy, mcmc_time_to_target ? "" : ">= ", speedup_equal, replay_time_equal_accuracy,
                mcmc_time_to_target ? "" : ">= ", speedup_equal_replay);
  }
  std::printf("\nTargets%s\n", comparable_setup ? "" : " (NOTE: not the reference setup of 100 trucks, 1024 particles, 2 threads)");
  std::printf("  whole replay <= %.0f s (1024 particles, 2 cores): %8.2f s   %s\n", kTargetReplayS, smc_wall_s,
              status(replay_met).c_str());
  std::printf("  p50 per-truck latency <= %.1f s:               %8.3f s   %s\n", kTargetP50S, p50,
              status(p50_met).c_str());
  std::printf("  integrator share >= %.0f %% (estimate):          %8.1f %%   %s\n", 100 * kTargetShare, 100 * share,
              status(share_met).c_str());
  std::printf("  SMC >= %.0fx faster than MCMC, same accuracy:   %7.3gx     %s [%s]\n", kTargetSpeedup, speedup_judged,
              speedup_status.c_str(), speedup_basis.c_str());
  std::fprintf(stderr, "(checksum %g)\n", calibration.sink);

  const std::string share_method =
      "estimate: integrator_passes x cost_per_pass / (smc_wall_s x threads); cost_per_pass is the median per-pass "
      "time of single-threaded Site::impact_factors calls on " +
      std::to_string(kCalibrationBatch) + "-truck batches of realistic trucks, measured in this run (" +
      std::to_string(kCalibrationReps / 2) + " reps before and " +
      std::to_string(kCalibrationReps - kCalibrationReps / 2) +
      " after the SMC replay); the CPU-time budget is wall time x threads";
  const std::string mcmc_time_method =
      "ESS (Geyer, chain_effective_sample_size) of each hyperparameter on prefixes of the kept chain every " +
      std::to_string(kEssPrefixStep) +
      " sweeps; the first prefix where the minimum over the 7 reaches 400, linearly interpolated from the previous "
      "prefix; time = init (grid search) + (burn_in + kept sweeps) x (wall - init) / iterations";

  if (!json_path.empty()) {
    nlohmann::json j;
    j["benchmark"] = "fit";
    j["config"] = {{"road", "AS1"},       {"trucks", trucks},           {"noise_sd", kNoiseSd}, {"final_sweeps", final_sweeps},
                   {"seed", seed},         {"particles", particles},     {"threads", threads_used},
                   {"mcmc_iterations", mcmc_iterations}, {"mcmc_burn_in", burn_in}, {"mcmc_thin", 1},
                   {"sensors", site.sensors()}, {"lift_offs", log.lift_offs}};
    j["machine"] = {{"hardware_threads", hardware_threads}, {"cpu", cpu_model()}, {"isa", isa_name()}};
    j["smc"] = {{"wall_s", smc_wall_s},
                {"latency_s",
                 {{"p50", p50}, {"p99", p99}, {"mean", latency_mean}, {"max", latency_max}, {"total", latency_total},
                  {"quantile_definition", "linear interpolation (type 7) over the per-truck latencies"}}},
                {"per_truck_latency_s", latency_s},
                {"stage_wall_time_total_s", stage_wall_s},
                {"process_cpu_s", smc_cpu_s},
                {"cores_busy_average", cores_used},
                {"load_average_1min", {{"before", load_before}, {"after", load_after_smc}}},
                {"steps_hitting_max_mh_sweeps", capped_steps},
                {"max_mh_sweeps_per_step", smc_options.sampler.schedule.max_sweeps},
                {"newest_block_acceptance_mean", newest_acceptance},
                {"integrator_passes", smc_passes},
                {"passes_per_s", passes_per_s},
                {"tempering_steps", tempering_steps},
                {"mh_sweeps", mh_sweeps},
                {"resamplings", resamplings},
                {"final_ess", cloud.weight_ess},
                {"final_sweeps", {{"sweeps", final_sweeps}, {"wall_s", final_s}, {"integrator_passes", final_passes},
                                  {"acceptance_last_sweep", final_acceptance}}},
                {"log_evidence", cloud.log_evidence}};
    j["integrator_calibration"] = {{"batch_trucks", kCalibrationBatch},
                                   {"threads", 1},
                                   {"us_per_pass_median", us_per_pass},
                                   {"us_per_pass_before_replay", calibration_before},
                                   {"us_per_pass_after_replay", calibration_after}};
    j["integrator_share"] = {{"value", share},
                             {"integrator_cpu_s", integrator_cpu_s},
                             {"method", share_method},
                             {"share_of_process_cpu", share_of_process_cpu},
                             {"share_of_process_cpu_method",
                              "diagnostic: the same integrator CPU estimate over the process CPU time "
                              "(CLOCK_PROCESS_CPUTIME_ID) of the replay"}};
    nlohmann::json trace = nlohmann::json::array();
    for (const auto& p : ess_trace) trace.push_back({{"kept", p.kept}, {"time_s", p.time_s}, {"ess", p.ess}, {"min_ess", p.min_ess}});
    j["mcmc"] = {{"wall_s", mcmc.wall_seconds},
                 {"init_s", mcmc.init_seconds},
                 {"process_cpu_s", mcmc_cpu_s},
                 {"load_average_1min_after", load_after_mcmc},
                 {"seconds_per_sweep", sweep_s},
                 {"iterations", mcmc.iterations},
                 {"burn_in", mcmc.burn_in},
                 {"kept", kept},
                 {"integrator_passes", mcmc.integrator_passes},
                 {"latent_acceptance", mcmc.latent_acceptance},
                 {"z_acceptance", mcmc.z_acceptance},
                 {"ess_target", kEssTarget},
                 {"time_to_ess_target_s", mcmc_time_to_target ? nlohmann::json(*mcmc_time_to_target) : nlohmann::json()},
                 {"kept_sweeps_to_ess_target", kept_to_target ? nlohmann::json(*kept_to_target) : nlohmann::json()},
                 {"reached", mcmc_time_to_target.has_value()},
                 {"time_to_ess_target_extrapolated_s",
                  mcmc_time_extrapolated ? nlohmann::json(*mcmc_time_extrapolated) : nlohmann::json()},
                 {"extrapolation_method",
                  "only when not reached: kept sweeps x 400 / final min ESS (ESS linear in sweeps), same time model; "
                  "never used for a target status"},
                 {"time_method", mcmc_time_method},
                 {"ess_final", ess_final.ess},
                 {"ess_trace", trace}};
    j["accuracy"] = accuracy;
    j["accuracy_max_abs_smd"] = max_abs_smd;
    j["accuracy_max_abs_quantile_difference"] = max_abs_dq;
    j["speedup_smc_vs_mcmc_to_ess400"] = {
        {"value", speedup},
        {"lower_bound", !mcmc_time_to_target.has_value()},
        {"extrapolated", mcmc_time_extrapolated ? nlohmann::json(*mcmc_time_extrapolated / smc_wall_s) : nlohmann::json()}};
    if (equal_accuracy) {
      nlohmann::json per = nlohmann::json::object();
      for (int k = 0; k < fleet::kHyperCount; ++k) {
        const auto K = static_cast<std::size_t>(k);
        per[std::string(fleet::kHyperNames[K])] = {{"scatter_of_mean", scatter.scatter[K]},
                                                   {"posterior_sd", scatter.posterior_sd[K]},
                                                   {"equivalent_ess", scatter.equivalent_ess[K]}};
      }
      j["smc_seed_scatter"] = {{"runs", scatter.runs},
                               {"seeds", {seed, seed + static_cast<std::uint64_t>(accuracy_seeds)}},
                               {"per_parameter", per},
                               {"min_equivalent_ess", scatter.min_ess},
                               {"min_equivalent_ess_90", {scatter.min_ess_lo90, scatter.min_ess_hi90}},
                               {"worst_parameter", std::string(fleet::kHyperNames[static_cast<std::size_t>(scatter.worst)])},
                               {"smc_time_to_equivalent_ess_400_s", smc_time_equal_accuracy},
                               {"speedup_at_equal_accuracy", speedup_equal},
                               {"replay_only",
                                {{"min_equivalent_ess", scatter_replay.min_ess},
                                 {"min_equivalent_ess_90", {scatter_replay.min_ess_lo90, scatter_replay.min_ess_hi90}},
                                 {"worst_parameter",
                                  std::string(fleet::kHyperNames[static_cast<std::size_t>(scatter_replay.worst)])},
                                 {"per_parameter_equivalent_ess", scatter_replay.equivalent_ess},
                                 {"smc_time_to_equivalent_ess_400_s", replay_time_equal_accuracy},
                                 {"speedup_at_equal_accuracy", speedup_equal_replay}}},
                               {"method",
                                "equivalent ESS = (mean posterior sd / sd of the posterior means over the replays)^2; "
                                "time = (SMC replay + final sweeps) wall x 400 / smallest equivalent ESS (error variance "
                                "~ 1/particles, cost ~ particles); 90 % interval from chi-squared(runs - 1); replay_only: "
                                "the same at the end of each replay, before its final sweeps"}};
    }
    j["targets"] = nlohmann::json::array(
        {{{"name", "whole replay <= 20 s (1024 particles, 2 cores)"}, {"value", smc_wall_s}, {"met", replay_met}},
         {{"name", "p50 per-truck latency <= 0.2 s"}, {"value", p50}, {"met", p50_met}},
         {{"name", "integrator share >= 70 % (estimate)"}, {"value", share}, {"met", share_met}},
         {{"name", "SMC >= 10x faster than MCMC to the same accuracy"}, {"value", speedup_judged},
          {"met", speedup_met}, {"status", speedup_status}, {"basis", speedup_basis}}});
    j["reference_setup"] = comparable_setup;
    std::ofstream out(json_path);
    out << j.dump(2) << "\n";
    if (!out) {
      std::cerr << "fit_benchmark: cannot write " << json_path << "\n";
      return 74;
    }
  }

  if (!markdown_path.empty()) {
    std::ostringstream md;
    md << "# Fit benchmark: SMC replay vs batch MCMC\n\n"
       << trucks << "-truck AS1 fleet drawn from Table 1, sigma_IF = " << kNoiseSd << ", seed " << seed << ", "
       << site.sensors() << " sensors. Machine: " << hardware_threads << " hardware threads, " << cpu_model()
       << ", ISA " << isa_name() << ". SMC: " << particles << " particles, " << threads_used
       << " threads, default options, then " << final_sweeps << " final rejuvenation sweeps (as `ssrfleet fit`). MCMC: "
       << mcmc_iterations << " sweeps, burn-in " << burn_in
       << ", thin 1, single threaded.\n\n"
       << "| metric | value |\n|---|---|\n"
       << "| SMC whole replay (wall) | " << fmt("%.2f", smc_wall_s) << " s |\n"
       << "| SMC per-truck latency p50 / p99 / mean / max | " << fmt("%.3f", p50) << " / " << fmt("%.3f", p99) << " / "
       << fmt("%.3f", latency_mean) << " / " << fmt("%.3f", latency_max) << " s |\n"
       << "| SMC integrator passes | " << smc_passes << " |\n"
       << "| SMC passes per second (wall) | " << fmt("%.0f", passes_per_s) << " |\n"
       << "| SMC tempering steps / MH sweeps / resamplings | " << tempering_steps << " / " << mh_sweeps << " / "
       << resamplings << " |\n"
       << "| SMC tempering steps whose MH sweeps hit max_steps (" << smc_options.sampler.schedule.max_sweeps << ") | "
       << fmt("%.1f", 100.0 * capped_steps / std::max(1, tempering_steps)) << " % |\n"
       << "| SMC newest-truck MH acceptance (mean over steps) | " << fmt("%.2f", newest_acceptance) << " |\n"
       << "| SMC final ESS | " << fmt("%.0f", cloud.weight_ess) << " |\n"
       << "| SMC final rejuvenation: sweeps / wall / integrator passes | " << final_sweeps << " / " << fmt("%.2f", final_s)
       << " s / " << final_passes << " |\n"
       << "| SMC process CPU time / cores busy on average | " << fmt("%.2f", smc_cpu_s) << " s / "
       << fmt("%.2f", cores_used) << " |\n"
       << "| Load average (1 min) before / after the replay | " << fmt("%.2f", load_before) << " / "
       << fmt("%.2f", load_after_smc) << " |\n"
       << "| Integrator cost per pass (calibrated, " << kCalibrationBatch << "-truck batches, 1 thread) | "
       << fmt("%.3f", us_per_pass) << " us |\n"
       << "| Integrator share (estimate*) | " << fmt("%.1f", 100 * share) << " % |\n"
       << "| Integrator share of the CPU time the replay actually used (diagnostic) | "
       << fmt("%.1f", 100 * share_of_process_cpu) << " % |\n"
       << "| MCMC wall (all sweeps) | " << fmt("%.2f", mcmc.wall_seconds) << " s |\n"
       << "| MCMC integrator passes | " << mcmc.integrator_passes << " |\n"
       << "| MCMC time to ESS >= 400 on all 7 | "
       << (mcmc_time_to_target ? fmt("%.2f", *mcmc_time_to_target) + " s (" + fmt("%.0f", *kept_to_target) +
                                     " kept sweeps after burn-in)"
                               : "not reached (min ESS " + fmt("%.0f", ess_final.min_ess) + ")" +
                                     (mcmc_time_extrapolated ? "; extrapolated " + fmt("%.2f", *mcmc_time_extrapolated) +
                                                                   " s (ESS linear in sweeps)"
                                                             : std::string()))
       << " |\n"
       << "| SMC speed-up vs MCMC to ESS 400 | " << (mcmc_time_to_target ? "" : ">= ") << fmt("%.3g", speedup) << "x"
       << (mcmc_time_extrapolated ? " (extrapolated " + fmt("%.3g", *mcmc_time_extrapolated / smc_wall_s) + "x)"
                                  : std::string())
       << " |\n"
       << (equal_accuracy ? "| SMC equivalent ESS (smallest, " + std::string(fleet::kHyperNames[static_cast<std::size_t>(scatter.worst)]) +
                                "; from " + std::to_string(scatter.runs) + " seeds) | " + fmt("%.0f", scatter.min_ess) +
                                " (90 % interval " + fmt("%.0f", scatter.min_ess_lo90) + "-" +
                                fmt("%.0f", scatter.min_ess_hi90) + ") |\n| SMC equivalent ESS at the end of the replay, "
                                "before the final sweeps (smallest, " +
                                std::string(fleet::kHyperNames[static_cast<std::size_t>(scatter_replay.worst)]) + ") | " +
                                fmt("%.0f", scatter_replay.min_ess) + " (90 % interval " +
                                fmt("%.0f", scatter_replay.min_ess_lo90) + "-" + fmt("%.0f", scatter_replay.min_ess_hi90) +
                                ") |\n| SMC time to an equivalent ESS of 400 (replay and final sweeps) | " +
                                fmt("%.2f", smc_time_equal_accuracy) + " s |\n| SMC speed-up vs MCMC at equal accuracy | " +
                                (mcmc_time_to_target ? "" : ">= ") + fmt("%.3g", speedup_equal) + "x (replay alone, no final "
                                "sweeps: " + (mcmc_time_to_target ? "" : ">= ") + fmt("%.3g", speedup_equal_replay) + "x) |\n"
                          : std::string())
       << "\n"
       << "\\* " << share_method << ".\n\nMCMC time to ESS: " << mcmc_time_method << ".\n\n"
       << "## Targets" << (comparable_setup ? "" : " (not the reference setup)") << "\n\n"
       << "| target | value | status |\n|---|---|---|\n"
       << "| whole replay <= 20 s (1024 particles, 2 cores) | " << fmt("%.2f", smc_wall_s) << " s | "
       << status(replay_met) << " |\n"
       << "| p50 per-truck latency <= 0.2 s | " << fmt("%.3f", p50) << " s | " << status(p50_met) << " |\n"
       << "| integrator share >= 70 % (estimate) | " << fmt("%.1f", 100 * share) << " % | " << status(share_met)
       << " |\n"
       << "| SMC >= 10x faster than MCMC to the same accuracy (" << speedup_basis << ") | " << fmt("%.3g", speedup_judged)
       << "x | " << speedup_status << " |\n\n"
       << "## Accuracy\n\nSMD = (mean_SMC - mean_MCMC) / sd_MCMC; dq = (q_SMC - q_MCMC) / (MCMC 95 % width).\n\n"
       << "| parameter | truth | SMC mean | SMC sd | SMC 95 % | MCMC mean | MCMC sd | MCMC 95 % | MCMC ESS | SMD | "
          "dq025 | dq975 | sd ratio |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (int j = 0; j < fleet::kHyperCount; ++j) {
      const auto& s = smc_summary[static_cast<std::size_t>(j)];
      const auto& m = mcmc_summary[static_cast<std::size_t>(j)];
      const double width = m.q975 - m.q025;
      md << "| " << fleet::kHyperNames[static_cast<std::size_t>(j)] << " | "
         << fmt("%.4g", kTruth[static_cast<std::size_t>(j)]) << " | " << fmt("%.4g", s.mean) << " | "
         << fmt("%.3g", s.sd) << " | [" << fmt("%.4g", s.q025) << ", " << fmt("%.4g", s.q975) << "] | "
         << fmt("%.4g", m.mean) << " | " << fmt("%.3g", m.sd) << " | [" << fmt("%.4g", m.q025) << ", "
         << fmt("%.4g", m.q975) << "] | " << fmt("%.0f", ess_final.ess[static_cast<std::size_t>(j)]) << " | "
         << fmt("%.2f", (s.mean - m.mean) / m.sd) << " | " << fmt("%.2f", (s.q025 - m.q025) / width) << " | "
         << fmt("%.2f", (s.q975 - m.q975) / width) << " | " << fmt("%.2f", s.sd / m.sd) << " |\n";
    }
    std::ofstream out(markdown_path);
    out << md.str();
    if (!out) {
      std::cerr << "fit_benchmark: cannot write " << markdown_path << "\n";
      return 74;
    }
  }
  return 0;
}
