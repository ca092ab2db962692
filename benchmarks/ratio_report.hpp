// The ratio benchmark's results (ratio_benchmark.cpp measures them) and how they are written: one
// JSON file with every number, and a Markdown summary with the ratio table, then per N the
// per-hyperparameter table and the accuracy check (accuracy.hpp). Kept apart from the measuring
// so each file reads on its own.
#pragma once

#include <array>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "accuracy.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet_presets.hpp"
#include "model/fleet_model.hpp"
#include "report_format.hpp"
#include "run_info.hpp"
#include "seed_scatter.hpp"
#include "smc_fit.hpp"

namespace ssrfleet::bench::ratio {

// What the Markdown and JSON call the data seed: the fleet draw and the noise of every N.
inline constexpr int kDataSeed = 1;

inline constexpr double kTargetEss = 400.0;
inline constexpr int kCheckEvery = 500;
inline constexpr int kFirstSmcSeed = 100;

struct SmcResult {
  int seeds = 0;
  std::vector<double> wall_s;  // per fit: replay + final sweeps
  double mean_wall_s = 0.0;
  // Per fit: the part of wall_s spent building the trucks' tables (MarginalTarget::table_seconds),
  // which does not grow with the particles: only the rest is scaled to ESS 400.
  std::vector<double> table_s;
  double mean_table_s = 0.0;
  SeedScatter scatter;  // of the posterior fit reports: the pool of the final sweeps' clouds
  double time_to_400_s = 0.0, time_to_400_lo_s = 0.0, time_to_400_hi_s = 0.0;
  // The same fits summarised from the last sweep's cloud alone (what fit reported before the pool),
  // side by side: what pooling buys.
  SeedScatter scatter_last;
  double time_to_400_last_s = 0.0;
  std::vector<double> one_more_truck_s;  // one absorb per fit
  double one_more_mean_s = 0.0, one_more_max_s = 0.0;
  std::array<double, fleet::kHyperCount> mean{};  // over seeds of the posterior mean
  std::vector<HyperSummary> runs;                 // per seed, for the accuracy check
  std::string error;                              // what a fit threw ("" = every fit ran)
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
  // Set when no chain ran here and a stored reference (--reference, stored_reference.hpp) stands
  // in: only iterations, burn_in, mean, sd, ess_full, min_ess_full and worst_full are filled; every
  // time is NaN, so no ratio is reported.
  std::string reference_file;
  std::uint64_t reference_seed = 0;
  std::string reference_commit;
};

struct NResult {
  int trucks = 0;
  double load_before = 0.0, load_after = 0.0;
  std::string started, finished;
  SmcResult smc;
  McmcResult mcmc;
  double ratio = 0.0;               // MCMC time to 400 / SMC time to 400
  double ratio_last = 0.0;          // the same with the SMC's last cloud alone
  double ratio_lo = 0.0, ratio_hi = 0.0;  // from the SMC ESS interval
  double one_more_ratio = 0.0;      // MCMC time to 400 / one absorb
  Accuracy accuracy;                // each SMC seed against the whole MCMC chain
};

inline void write_results(const std::vector<NResult>& results, const std::vector<int>& requested, int seeds,
                          const FleetPreset& preset, const std::string& commit, long nproc, const std::string& started,
                          const std::string& json_path, const std::string& md_path,
                          const std::string& smc_options_note = "") {
  // "default options", or which MarginalTarget options a run overrode (ratio_benchmark --lateral-piece-fraction ...).
  const std::string smc_options = smc_options_note.empty() ? "default options" : "default options but" + smc_options_note;
  nlohmann::json j;
  j["benchmark"] = "ratio";
  j["started_utc"] = started;
  j["written_utc"] = utc_now();
  j["commit"] = commit;
  j["nproc"] = nproc;
  j["trucks_requested"] = requested;
  j["complete"] = results.size() == requested.size();
  j["settings"] = {{"fleet", preset_json(preset)},
                   {"road", preset.road},
                   {"sigma_if", preset.sigma_if},
                   {"data_seed", kDataSeed},
                   {"smc", {{"particles", fleet::MarginalSmc::Options{}.sampler.particles}, {"threads", 2},
                            {"seeds", seeds}, {"first_seed", kFirstSmcSeed},
                            {"final_sweeps", fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps}, {"options", smc_options}}},
                   {"mcmc", {{"threads", 2}, {"seed", 1}, {"options", "default (interweave K_t/sigma_kt, best-fit start)"},
                             {"ess_check_every_sweeps", kCheckEvery}}},
                   {"target_ess", kTargetEss},
                   {"smc_time_to_400",
                    "mean table time per fit + (mean wall - mean table time) x 400 / smallest equivalent ESS"},
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
    e["smc"] = {{"error", s.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.error)},
                {"wall_per_fit_s", s.wall_s},
                {"mean_wall_per_fit_s", s.mean_wall_s},
                {"table_s_per_fit", s.table_s},
                {"mean_table_s_per_fit", s.mean_table_s},
                {"equivalent_ess", hyper_json(s.scatter.equivalent_ess)},
                {"posterior_sd", hyper_json(s.scatter.posterior_sd)},
                {"seed_scatter_sd", hyper_json(s.scatter.scatter)},
                {"posterior_mean", hyper_json(s.mean)},
                {"min_equivalent_ess", num(s.scatter.min_ess)},
                {"min_equivalent_ess_parameter", std::string(fleet::kHyperNames[s.scatter.worst])},
                {"min_equivalent_ess_90", {num(s.scatter.min_ess_lo90), num(s.scatter.min_ess_hi90)}},
                {"time_to_ess_400_s", num(s.time_to_400_s)},
                {"time_to_ess_400_90_s", {num(s.time_to_400_lo_s), num(s.time_to_400_hi_s)}},
                {"last_cloud_only", {{"equivalent_ess", hyper_json(s.scatter_last.equivalent_ess)},
                                     {"min_equivalent_ess", num(s.scatter_last.min_ess)},
                                     {"min_equivalent_ess_parameter", std::string(fleet::kHyperNames[s.scatter_last.worst])},
                                     {"min_equivalent_ess_90", {num(s.scatter_last.min_ess_lo90), num(s.scatter_last.min_ess_hi90)}},
                                     {"time_to_ess_400_s", num(s.time_to_400_last_s)},
                                     {"ratio_mcmc_over_smc", num(r.ratio_last)}}},
                {"one_more_truck_s", s.one_more_truck_s},
                {"one_more_truck_mean_s", s.one_more_mean_s},
                {"one_more_truck_max_s", s.one_more_max_s}};
    nlohmann::json trace = nlohmann::json::array();
    for (const auto& [len, ess] : m.min_ess_trace) trace.push_back({len, num(ess)});
    e["mcmc"] = {{"source", m.reference_file.empty() ? nlohmann::json("run here")
                                                    : nlohmann::json({{"stored_reference", m.reference_file},
                                                                      {"chain_seed", m.reference_seed},
                                                                      {"commit", m.reference_commit}})},
                 {"iterations", m.iterations},
                 {"burn_in", m.burn_in},
                 {"wall_s", num(m.wall_s)},
                 {"init_s", num(m.init_s)},
                 {"per_sweep_s", num(m.per_sweep_s)},
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
    e["accuracy"] = accuracy_json(r.accuracy);
    e["ratio_mcmc_over_smc"] = num(r.ratio);
    e["ratio_mcmc_over_smc_90"] = {num(r.ratio_lo), num(r.ratio_hi)};
    e["ratio_mcmc_to_400_over_one_more_truck"] = num(r.one_more_ratio);
    e["target_ratio"] = r.trucks >= 10000 ? nlohmann::json(10.0) : (r.trucks <= 100 ? nlohmann::json(1.0) : nlohmann::json(nullptr));
    per_n.push_back(e);
  }
  j["results"] = per_n;
  j["targets"] = "MCMC/SMC time to ESS 400 >= 1x at N = 100, >= 10x at N = 10,000; "
                 "accuracy against a reference chain with ESS >= 1,000 on all 7";
  if (!json_path.empty()) {
    std::ofstream f = open_results_file(json_path);
    f << j.dump(2) << "\n";
  }
  if (md_path.empty()) return;
  std::ofstream f = open_results_file(md_path);
  f << "# Ratio benchmark: SMC vs batch MCMC, wall time to ESS 400 on all 7 hyperparameters"
    << (results.size() == requested.size() ? "" : " (PARTIAL)") << "\n\n";
  f << "Fleet `" << preset.name << "`: " << preset.description << ", road " << preset.road << ", sigma_IF "
    << preset.sigma_if << ", data seed " << kDataSeed << ". Truth (generating parameters): " << truth_line(preset)
    << ". Commit " << commit << ", nproc " << nproc << ", started " << started << ", written " << utc_now()
    << ". The machine may be shared: see the load.\n\n";
  f << "- SMC: fleet::MarginalSmc, " << smc_options << ", 1,024 particles, 2 threads, replay then rejuvenate("
    << fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps << "); " << seeds
    << " seeds (100, ...) on the same data. Equivalent ESS = (mean posterior sd)^2 / (variance of the "
    << seeds << " posterior means), the smallest over the 7. **SMC time to ESS 400 = T + (mean wall per fit - T) x 400 / "
       "smallest equivalent ESS**, T the mean time per fit spent building the trucks' tables, which does not "
       "change with the particle count (only the rest would shrink or grow with the particles an ESS of 400 "
       "needs). With " << seeds << " seeds the equivalent ESS carries a chi-square("
    << seeds - 1 << ") factor: 90 % interval shown.\n";
  f << "- The SMC posterior is what `fit` reports: the clouds of all its final sweeps pooled "
       "(MarginalSmc::rejuvenate). The last column shows the same fits summarised from the last sweep's "
       "cloud alone.\n";
  f << "- MCMC: fleet::run_batch_mcmc, default options (interweaving on, best-fit start), 2 threads, seed 1; one "
       "long chain; the first prefix of the kept chain (checked every "
    << kCheckEvery << " sweeps) whose smallest Geyer ESS over the 7 reaches 400. **Time = init + (burn-in + kept "
       "sweeps) x (wall - init) / iterations.**\n";
  f << "- One more truck: one absorb() of a fresh simulated truck into each SMC fit after its final sweeps (mean "
       "over the fits), against re-running the MCMC to ESS 400.\n\n";
  f << "| N | SMC wall/fit s (tables) | smallest equiv. ESS (param) [90 %] | SMC time to 400 s [90 %] | MCMC time to 400 s "
       "(sweeps incl. burn-in) | ratio MCMC/SMC [90 %] | target | one more truck (SMC) s | MCMC/one truck | "
       "load 1-min before/after | last cloud alone: smallest equiv. ESS, ratio |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : results) {
    const auto& s = r.smc;
    const auto& m = r.mcmc;
    std::string mc = !m.reference_file.empty()
                         ? "not run (stored reference)"
                     : m.reached ? fmt(m.time_to_400_s, 1) + " (" + std::to_string(m.burn_in + m.kept_sweeps_to_400) + ")"
                                 : "not reached in " + std::to_string(m.iterations) + " (extrap. " +
                                       fmt(m.extrapolated_time_s, 1) + ")";
    f << "| " << r.trucks << " | " << fmt(s.mean_wall_s, 2) << " (" << fmt(s.mean_table_s, 2) << ") | "
      << fmt(s.scatter.min_ess, 0) << " ("
      << fleet::kHyperNames[s.scatter.worst] << ") [" << fmt(s.scatter.min_ess_lo90, 0) << ", "
      << fmt(s.scatter.min_ess_hi90, 0) << "] | " << fmt(s.time_to_400_s, 2) << " [" << fmt(s.time_to_400_lo_s, 2)
      << ", " << fmt(s.time_to_400_hi_s, 2) << "] | " << mc << " | " << fmt(r.ratio, 2) << " [" << fmt(r.ratio_lo, 2)
      << ", " << fmt(r.ratio_hi, 2) << "]" << (m.reached || !m.reference_file.empty() ? "" : " (extrap.)") << " | "
      << (r.trucks <= 100 ? ">= 1" : (r.trucks >= 10000 ? ">= 10" : "")) << " | " << fmt(s.one_more_mean_s, 4)
      << " (max " << fmt(s.one_more_max_s, 4) << ") | " << fmt(r.one_more_ratio, 0) << " | " << fmt(r.load_before, 2)
      << " / " << fmt(r.load_after, 2) << " | " << fmt(s.scatter_last.min_ess, 0) << " ("
      << fleet::kHyperNames[s.scatter_last.worst] << "), " << fmt(r.ratio_last, 2) << " |\n";
  }
  f << "\nTargets: ratio >= 1 at N = 100, >= 10 at N = 10,000.\n\n";
  f << "| N | accuracy verdict | MCMC full-chain min ESS (param) |\n|---|---|---|\n";
  for (const auto& r : results)
    f << "| " << r.trucks << " | " << verdict_name(r.accuracy.verdict) << " | "
      << fmt(r.accuracy.reference_min_ess, 0) << " (" << fleet::kHyperNames[r.accuracy.reference_worst] << ") |\n";
  for (const auto& r : results) {
    const auto& s = r.smc;
    const auto& m = r.mcmc;
    f << "\n## N = " << r.trucks << "\n\n";
    if (!s.error.empty()) f << "**SMC FAILED** (no posterior, no ratio): `" << s.error << "`\n\n";
    f << "SMC wall per fit (s):";
    for (double w : s.wall_s) f << " " << fmt(w, 2);
    if (m.reference_file.empty())
      f << ". MCMC: " << m.iterations << " sweeps (burn-in " << m.burn_in << "), wall " << fmt(m.wall_s, 1)
        << " s, init " << fmt(m.init_s, 2) << " s, " << fmt(1e3 * m.per_sweep_s, 3) << " ms/sweep.\n\n";
    else
      f << ". MCMC: not run here; the stored reference `" << m.reference_file << "` (" << m.iterations
        << " sweeps, burn-in " << m.burn_in << ", chain seed " << m.reference_seed << ", commit " << m.reference_commit
        << ") stands for it: no ratio.\n\n";
    f << "| parameter | truth | SMC equiv. ESS | SMC posterior mean | MCMC ESS at the 400 prefix | MCMC ESS full "
         "chain | MCMC posterior mean | MCMC posterior sd | SMC posterior sd |\n|---|---|---|---|---|---|---|---|---|\n";
    const fleet::HyperVector truth = preset.truth();
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const auto H = static_cast<std::size_t>(h);
      f << "| " << fleet::kHyperNames[h] << " | " << fmt_g(truth[H]) << " | " << fmt(s.scatter.equivalent_ess[H], 0)
        << " | " << fmt_g(s.mean[H]) << " | " << (m.reached ? fmt(m.ess_at_400[H], 0) : "n/a") << " | "
        << fmt(m.ess_full[H], 0) << " | " << fmt_g(m.mean[H]) << " | " << fmt_g(m.sd[H]) << " | "
        << fmt_g(s.scatter.posterior_sd[H]) << " |\n";
    }
    f << "\n";
    write_accuracy_markdown(f, r.accuracy);
  }
}

}  // namespace ssrfleet::bench::ratio
