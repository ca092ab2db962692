// Ratio benchmark (docs/inference.md): the wall time to an equivalent ESS of 400 on
// all 7 hyperparameters, measured side by side in one run, for
//   (a) the marginal SMC core (fleet::MarginalSmc: default options, 1,024 particles, 2 threads, the
//       log replayed truck by truck, then rejuvenate(final_sweeps), the posterior the pool of every
//       final sweep's cloud, as fit reports it; the last cloud alone is reported beside it). Its Monte Carlo error is measured by
//       seed scatter (seed_scatter.hpp): S fits of the same data with seeds 100, ..., 100 + S - 1;
//       equivalent ESS per hyperparameter = (mean posterior sd)² / (variance of the S posterior
//       means), the smallest over the 7 counts. Time to ESS 400 = T + (mean wall per fit - T) x 400 /
//       smallest equivalent ESS, T the mean time a fit spends building the trucks' tables: the Monte
//       Carlo variance of an SMC estimate falls as 1 / particles and the particles' share of the cost
//       grows with them, but a truck's table is built once whatever the particle count (scaling the
//       whole wall, as this benchmark did until commit 7f86631, credited the SMC with table time it
//       would still spend at fewer particles). With S seeds the
//       equivalent ESS is known to a χ²(S - 1) / (S - 1) factor: its 90 % interval is printed.
//   (b) the batch MCMC baseline (fleet::run_batch_mcmc, default options: interweaving on, best-fit
//       start; 2 threads): one long chain; the first prefix of the kept chain (checked every 500
//       sweeps) where the smallest of the 7 chain ESS (Geyer) reaches 400. Time = init_seconds +
//       (burn_in + kept sweeps) x (wall - init) / iterations. If the chain never gets there, the
//       extrapolation from the whole chain is reported separately (and flagged).
//   (c) the cost of one more truck: one absorb() of a fresh simulated truck into each SMC fit after
//       its final sweeps, against re-running the MCMC to ESS 400.
//   (d) accuracy (accuracy.hpp): each SMC seed's posterior mean and sd against the
//       whole kept MCMC chain, which is the reference only if its ESS is >= 1,000 on all 7.
//       --reference FILE (a JSON of mcmc_reference_benchmark, same fleet, same data seed 1) judges
//       against that stored chain instead and runs no MCMC here: accuracy only, no ratio (at
//       10,000 trucks a chain long enough to judge by takes 1.5 h, beyond a side-by-side run).
// Data (--fleet, fleet_presets.hpp): the Table 1 fleet on AS1 with σ_IF = 0.02 (default), or the
// second fleet on AS2 with σ_IF = 0.03; seed 1 for the fleet draw and the noise. The machine may
// be shared: the 1-minute load average is recorded before and after each N.
//
//   ratio_benchmark [--fleet table1|second] [--trucks 100,1000] [--trucks N ...] [--seeds 8]
//                   [--json FILE] [--markdown FILE] [--mcmc-iterations I --mcmc-burn-in B]
//                   [--commit HASH] [--check-accuracy] [--reference FILE]
//                   [--lateral-piece-fraction F] [--lattice-fraction F]
// The last two override MarginalTarget::Options of the SMC fits (the tables' lateral pieces and
// lattice spacing), to measure what the tables' approximation does to the posterior.
// Default MCMC lengths: 40,000 / 5,000 sweeps at N <= 100, 45,000 / 5,000 above (at N = 1,000,
// 15,000 kept sweeps gave ESS 647 on sigma_kt; 40,000 kept make the reference's 1,000 with room).
// The results files are rewritten after every N, so an interrupted run keeps the finished ones.
// --check-accuracy: exit status 1 if any N fails for certain (a criterion missed against a long
// enough reference, or an SMC fit threw), else 3 if any N's reference is too short to judge by
// (no verdict), else 0.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "accuracy.hpp"
#include "fleet/batch_mcmc.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/simulator.hpp"
#include "fleet_presets.hpp"
#include "model/fleet_model.hpp"
#include "ratio_report.hpp"
#include "report_format.hpp"
#include "road/surface_presets.hpp"
#include "run_info.hpp"
#include "seed_scatter.hpp"
#include "smc_fit.hpp"
#include "stored_reference.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;
using namespace ssrfleet::bench::ratio;
using bench::fmt;
using bench::fmt_g;
using bench::load_average_1min;
using bench::run_command;
using bench::utc_now;

namespace {

using clock_type = std::chrono::steady_clock;

double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}

SmcResult run_smc(const site::Site& site, const fleet::SimulatedLog& log, const records::WimRecord& extra,
                  int seeds, const fleet::MarginalTarget::Options& target) {
  SmcResult r;
  r.seeds = seeds;
  std::vector<bench::RunSummary> runs, last_cloud;
  for (int s = 0; s < seeds; ++s) {
    fleet::MarginalSmc::Options o = bench::smc_options(static_cast<std::uint64_t>(kFirstSmcSeed + s), 2);
    o.target = target;
    fleet::MarginalSmc smc(site, o);
    const auto t0 = clock_type::now();
    bench::replay_and_rejuvenate(smc, log.records, o.sampler.schedule.final_sweeps);
    const double wall = seconds_since(t0);
    r.wall_s.push_back(wall);
    r.table_s.push_back(smc.target().table_seconds());
    const bench::HyperSummary summary = bench::summarise_hypers(smc.cloud());
    for (int h = 0; h < fleet::kHyperCount; ++h)
      r.mean[static_cast<std::size_t>(h)] += summary[static_cast<std::size_t>(h)].mean / seeds;
    r.runs.push_back(summary);
    runs.emplace_back(summary.begin(), summary.end());
    const bench::HyperSummary last = bench::summarise_hypers(smc.current_cloud());
    last_cloud.emplace_back(last.begin(), last.end());
    const auto t1 = clock_type::now();
    smc.absorb(extra);
    r.one_more_truck_s.push_back(seconds_since(t1));
    std::cerr << "  SMC seed " << kFirstSmcSeed + s << ": fit " << fmt(wall, 2) << " s (tables "
              << fmt(r.table_s.back(), 2) << " s), one more truck "
              << fmt(1e3 * r.one_more_truck_s.back(), 1) << " ms; posterior mean (sd):";
    // Every seed's posterior on the log as it finishes: a long run stopped part-way still says
    // what its finished fits found.
    for (int h = 0; h < fleet::kHyperCount; ++h)
      std::cerr << " " << fleet::kHyperNames[h] << " " << fmt_g(summary[static_cast<std::size_t>(h)].mean) << " ("
                << fmt_g(summary[static_cast<std::size_t>(h)].sd) << ")";
    std::cerr << "\n";
  }
  for (double w : r.wall_s) r.mean_wall_s += w / seeds;
  for (double t : r.table_s) r.mean_table_s += t / seeds;
  for (double w : r.one_more_truck_s) {
    r.one_more_mean_s += w / seeds;
    r.one_more_max_s = std::max(r.one_more_max_s, w);
  }
  r.scatter = bench::seed_scatter(runs);
  const auto time_to_400 = [&](double ess) {
    return r.mean_table_s + (r.mean_wall_s - r.mean_table_s) * kTargetEss / ess;
  };
  r.time_to_400_s = time_to_400(r.scatter.min_ess);
  r.time_to_400_lo_s = time_to_400(r.scatter.min_ess_hi90);  // more ESS, less time
  r.time_to_400_hi_s = time_to_400(r.scatter.min_ess_lo90);
  r.scatter_last = bench::seed_scatter(last_cloud);
  r.time_to_400_last_s = time_to_400(r.scatter_last.min_ess);
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


// The fresh truck for "one more truck": its own fleet draw and noise seed, and an id of its own.
records::WimRecord fresh_truck(const site::Site& site, const bench::FleetPreset& preset, int N) {
  const auto seed = static_cast<std::uint64_t>(1000 + N);
  auto trucks = fleet::draw_fleet(preset.distribution, 1, site.lateral_min_m(), site.lateral_max_m(), seed);
  trucks[0].truck_id = "EXTRA";
  return fleet::simulate_log(site, trucks, preset.sigma_if, seed).records.at(0);
}

// What a failed SMC leaves: the error, and NaN wherever a number would be (the reports print
// "n/a" and null), so no zero passes for a measurement.
SmcResult failed_smc(const std::string& error, int seeds) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SmcResult r;
  r.seeds = seeds;
  r.error = error;
  r.mean_wall_s = r.mean_table_s = r.time_to_400_s = r.time_to_400_lo_s = r.time_to_400_hi_s = nan;
  r.one_more_mean_s = r.one_more_max_s = nan;
  r.mean.fill(nan);
  r.scatter.scatter.fill(nan);
  r.scatter.posterior_sd.fill(nan);
  r.scatter.equivalent_ess.fill(nan);
  r.scatter.min_ess = r.scatter.min_ess_lo90 = r.scatter.min_ess_hi90 = nan;
  return r;
}

// Default MCMC length: at N <= 100 a sweep is cheap and 40,000 in all gave full-chain ESS 1,855;
// above, 45,000 (40,000 kept), since 15,000 kept gave 647 on sigma_kt at N = 1,000.
int default_mcmc_iterations(int N) { return N <= 100 ? 40000 : 45000; }

// A stored chain standing in for the one run here: its posterior and ESS, no times (NaN).
McmcResult from_stored_reference(const bench::StoredReference& ref) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  McmcResult r;
  r.reference_file = ref.path;
  r.reference_seed = ref.seed;
  r.reference_commit = ref.commit;
  r.iterations = ref.iterations;
  r.burn_in = ref.burn_in;
  r.wall_s = r.init_s = r.per_sweep_s = nan;
  r.mean = ref.mean;
  r.sd = ref.sd;
  r.ess_full = ref.ess;
  r.min_ess_full = std::numeric_limits<double>::infinity();
  for (int h = 0; h < fleet::kHyperCount; ++h)
    if (!(ref.ess[static_cast<std::size_t>(h)] >= r.min_ess_full)) {
      r.min_ess_full = ref.ess[static_cast<std::size_t>(h)];
      r.worst_full = h;
    }
  return r;
}

NResult measure(const site::Site& site, const bench::FleetPreset& preset, int N, int seeds, int mcmc_iterations,
                int mcmc_burn_in, const std::optional<bench::StoredReference>& stored,
                const fleet::MarginalTarget::Options& target) {
  NResult r;
  r.trucks = N;
  r.started = utc_now();
  r.load_before = load_average_1min();
  const fleet::SimulatedLog log = bench::simulate_preset(site, preset, N, kDataSeed);
  const records::WimRecord extra = fresh_truck(site, preset, N);

  std::cerr << "N=" << N << ": SMC, " << seeds << " seeds (load " << fmt(r.load_before, 2) << ")\n";
  // A fit that throws is a result too (the SMC gave no posterior): recorded, and the MCMC still
  // runs, so the reference is there for the next attempt.
  try {
    r.smc = run_smc(site, log, extra, seeds, target);
  } catch (const std::exception& e) {
    r.smc = failed_smc(e.what(), seeds);
    std::cerr << "  SMC FAILED: " << r.smc.error << "\n";
  }
  if (stored) {
    r.mcmc = from_stored_reference(*stored);
  } else {
    const int it = mcmc_iterations > 0 ? mcmc_iterations : default_mcmc_iterations(N);
    const int bi = mcmc_burn_in > 0 ? mcmc_burn_in : 5000;
    std::cerr << "N=" << N << ": MCMC, " << it << " sweeps, burn-in " << bi << "\n";
    r.mcmc = run_mcmc(site, log, it, bi);
  }
  r.load_after = load_average_1min();
  r.finished = utc_now();
  const double mcmc_t = r.mcmc.reached ? r.mcmc.time_to_400_s : r.mcmc.extrapolated_time_s;
  r.ratio = mcmc_t / r.smc.time_to_400_s;
  r.ratio_last = mcmc_t / r.smc.time_to_400_last_s;
  r.ratio_lo = mcmc_t / r.smc.time_to_400_hi_s;
  r.ratio_hi = mcmc_t / r.smc.time_to_400_lo_s;
  r.one_more_ratio = mcmc_t / r.smc.one_more_mean_s;
  r.accuracy = bench::judge_accuracy(r.smc.runs, bench::Reference{r.mcmc.mean, r.mcmc.sd, r.mcmc.ess_full},
                                     kFirstSmcSeed);
  return r;
}

void print_summary(const NResult& r) {
  const int N = r.trucks;
  const auto& s = r.smc;
  const auto& m = r.mcmc;
  std::cout << "N=" << N << " (load 1-min " << fmt(r.load_before, 2) << " -> " << fmt(r.load_after, 2) << ")\n";
  if (!s.error.empty())
    std::cout << "  SMC FAILED: " << s.error << "\n";
  else
    std::cout << "  SMC: mean wall per fit " << fmt(s.mean_wall_s, 2) << " s (replay + "
              << fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps << " final sweeps); smallest equivalent ESS "
              << fmt(s.scatter.min_ess, 0) << " (" << fleet::kHyperNames[s.scatter.worst] << "), 90 % ["
              << fmt(s.scatter.min_ess_lo90, 0) << ", " << fmt(s.scatter.min_ess_hi90, 0) << "]; tables "
              << fmt(s.mean_table_s, 2) << " s per fit\n"
              << "       time to ESS 400 = tables + (wall - tables) x 400 / smallest equivalent ESS = " << fmt(s.time_to_400_s, 2)
              << " s, 90 % [" << fmt(s.time_to_400_lo_s, 2) << ", " << fmt(s.time_to_400_hi_s, 2) << "]\n"
              << "       the last cloud alone: smallest equivalent ESS " << fmt(s.scatter_last.min_ess, 0) << " ("
              << fleet::kHyperNames[s.scatter_last.worst] << "), time to ESS 400 " << fmt(s.time_to_400_last_s, 2)
              << " s, ratio " << fmt(r.ratio_last, 2) << "\n";
  if (!m.reference_file.empty())
    std::cout << "  MCMC: not run; stored reference " << m.reference_file << " (" << m.iterations << " sweeps, burn-in "
              << m.burn_in << ", chain seed " << m.reference_seed << "): no ratio\n";
  else if (m.reached)
    std::cout << "  MCMC: ESS 400 on all 7 after " << m.kept_sweeps_to_400 << " kept sweeps (+" << m.burn_in
              << " burn-in): time to ESS 400 " << fmt(m.time_to_400_s, 2) << " s (init " << fmt(m.init_s, 2)
              << " s, " << fmt(1e3 * m.per_sweep_s, 3) << " ms/sweep, whole chain " << fmt(m.wall_s, 1) << " s)\n";
  else
    std::cout << "  MCMC: ESS 400 NOT reached in " << m.iterations - m.burn_in << " kept sweeps (min ESS "
              << fmt(m.min_ess_full, 0) << ", " << fleet::kHyperNames[m.worst_full] << "); EXTRAPOLATED "
              << fmt(m.extrapolated_sweeps, 0) << " kept sweeps, " << fmt(m.extrapolated_time_s, 2) << " s\n";
  std::cout << "  full-chain min ESS " << fmt(m.min_ess_full, 0) << " (" << fleet::kHyperNames[m.worst_full]
            << ")\n  ratio MCMC/SMC " << fmt(r.ratio, 2) << " [" << fmt(r.ratio_lo, 2) << ", "
            << fmt(r.ratio_hi, 2) << "]" << (m.reached || !m.reference_file.empty() ? "" : " (extrapolated)") << "\n"
            << "  one more truck (SMC absorb) mean " << fmt(1e3 * s.one_more_mean_s, 2) << " ms (max "
            << fmt(1e3 * s.one_more_max_s, 2) << " ms); MCMC re-run to 400 / one absorb = "
            << fmt(r.one_more_ratio, 0) << "\n"
            << std::flush;
  std::cout << "  accuracy vs the full MCMC chain: " << bench::verdict_name(r.accuracy.verdict);
  if (s.error.empty()) {
    std::cout << " (worst seed, mean offset in MCMC sd / sd ratio:";
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const auto& a = r.accuracy.per[static_cast<std::size_t>(h)];
      std::cout << " " << fleet::kHyperNames[h] << " " << fmt(a.worst_offset_sd, 2) << " / " << fmt(a.worst_sd_ratio, 2);
    }
    std::cout << ")";
  }
  std::cout << std::endl;
}

// --check-accuracy: 1 if any N failed for certain (a criterion missed against a long enough
// reference, or no SMC posterior), else 3 if any N's reference was too short to judge by, else 0.
int accuracy_exit_status(const std::vector<NResult>& results) {
  bool too_short = false, failed = false;
  for (const auto& r : results) {
    too_short = too_short || r.accuracy.verdict == bench::AccuracyVerdict::kReferenceTooShort;
    failed = failed || r.accuracy.verdict == bench::AccuracyVerdict::kFail ||
             r.accuracy.verdict == bench::AccuracyVerdict::kSmcFailed;
  }
  return failed ? 1 : (too_short ? 3 : 0);
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
  bool check_accuracy = false;
  std::string json_path, md_path, commit, fleet_name = "table1", reference_path;
  // The tables' approximation, overridable to measure its effect on the posterior (default: the
  // library's, and the reports say "default").
  fleet::MarginalTarget::Options target;
  std::string smc_options_note;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--trucks") {
      for (int n : parse_list(next())) trucks.push_back(n);
    } else if (a == "--fleet") {
      fleet_name = next();
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
    } else if (a == "--check-accuracy") {
      check_accuracy = true;
    } else if (a == "--reference") {
      reference_path = next();
    } else if (a == "--lateral-piece-fraction") {
      target.lateral_piece_fraction = std::stod(next());
      smc_options_note += " lateral_piece_fraction " + fmt_g(target.lateral_piece_fraction);
    } else if (a == "--lattice-fraction") {
      target.lattice_fraction = std::stod(next());
      smc_options_note += " lattice_fraction " + fmt_g(target.lattice_fraction);
    } else {
      std::cerr << "usage: ratio_benchmark [--fleet table1|second] [--trucks 100,1000] [--seeds 8] [--json FILE]\n"
                   "                       [--markdown FILE] [--mcmc-iterations I --mcmc-burn-in B] [--commit HASH]\n"
                   "                       [--check-accuracy] [--reference MCMC_REFERENCE_JSON]\n"
                   "                       [--lateral-piece-fraction F] [--lattice-fraction F]\n";
      return 2;
    }
  }
  const std::optional<bench::FleetPreset> preset = bench::find_fleet_preset(fleet_name);
  if (!preset) {
    std::cerr << "ratio_benchmark: --fleet must be one of " << bench::fleet_preset_names() << "\n";
    return 2;
  }
  std::optional<bench::StoredReference> stored;
  if (!reference_path.empty()) {
    try {
      stored = bench::read_stored_reference(reference_path);
    } catch (const std::exception& e) {
      std::cerr << "ratio_benchmark: " << e.what() << "\n";
      return 2;
    }
    if (stored->fleet != preset->name) {
      std::cerr << "ratio_benchmark: reference '" << reference_path << "' is for fleet '" << stored->fleet
                << "', not --fleet " << preset->name << "\n";
      return 2;
    }
    if (trucks.empty()) trucks = {stored->trucks};
    if (trucks.size() != 1 || trucks[0] != stored->trucks) {
      std::cerr << "ratio_benchmark: reference '" << reference_path << "' is for " << stored->trucks
                << " trucks: --trucks must be that one N\n";
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

  const site::Site site(road::preset_surface(preset->road), site::SiteOptions{});
  std::vector<NResult> results;
  for (int N : trucks) {
    results.push_back(measure(site, *preset, N, seeds, mcmc_iterations, mcmc_burn_in, stored, target));
    print_summary(results.back());
    write_results(results, trucks, seeds, *preset, commit, nproc, started, json_path, md_path, smc_options_note);
  }
  return check_accuracy ? accuracy_exit_status(results) : 0;
}
