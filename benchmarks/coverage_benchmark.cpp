// Coverage benchmark : are the SMC's 95 % intervals 95 %
// intervals? For data seeds 1, ..., S a fleet of N trucks is drawn and simulated (fleet_presets.hpp:
// the fleet draw and the noise both from the data seed), fitted as `ssrfleet fit` fits
// (fleet::MarginalSmc, default options: every record absorbed, then rejuvenate(final_sweeps)), and
// the weighted 2.5 % / 97.5 % quantiles of each hyperparameter (fleet::summarise_cloud, as the
// posterior file reports them) are checked against the truth, the generating distribution's
// parameters. All 7 are reported; K, K_t, Z, sigma_z and sigma_IF are judged: each must be
// covered in at least 17 of 20 data seeds (85 %; for other S, ceil(0.85 S)). sigma_k and
// sigma_kt are reported but not judged (the issue names the other five).
//
// The statistics of the check: with true coverage 95 % the count is Binomial(20, 0.95), and
// P(count < 17) = 1.6 %, so a correct sampler fails one given judged parameter that often, and
// at least one of the five up to 5 x 1.6 % = 8 % of the time (union bound); a sampler with true
// coverage 85 % still passes one parameter with probability 65 %. The reports print these
// probabilities for the S and threshold used. A fit that throws delivers no interval: it counts
// as a miss on all 7 and is reported as a failed fit.
//
//   coverage_benchmark [--fleet table1|second] [--trucks 1000] [--seeds 20] [--json FILE]
//                      [--markdown FILE] [--commit HASH] [--check]
// --check: exit status 1 if a judged hyperparameter is covered fewer times than required.
// Progress goes to stderr; the results files are rewritten after every seed (marked partial).
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <boost/math/distributions/binomial.hpp>
#include <nlohmann/json.hpp>

#include "fleet/marginal_smc.hpp"
#include "fleet_presets.hpp"
#include "model/fleet_model.hpp"
#include "report_format.hpp"
#include "road/surface_presets.hpp"
#include "run_info.hpp"
#include "smc_fit.hpp"

using namespace ssrfleet;
using bench::fmt;
using bench::fmt_g;

namespace {

constexpr double kNominalCoverage = 0.95;
constexpr double kRequiredFraction = 17.0 / 20.0;  // the target: at least 17 of 20
// Judged: K, K_t, Z, sigma_z, sigma_IF (fleet_model.hpp order).
constexpr std::array<bool, fleet::kHyperCount> kJudged = {true, false, true, false, true, true, true};

struct SeedOutcome {
  int data_seed = 0;
  double wall_s = 0.0;
  std::string error;  // what the fit threw ("" = it ran)
  bench::HyperSummary summary{};
  std::array<bool, fleet::kHyperCount> inside{};
};

struct Settings {
  bench::FleetPreset preset;
  int trucks = 1000, seeds = 20;
  std::string json_path, md_path, commit, started;
  long nproc = 0;
  double load_before = 0.0;
};

// ceil(0.85 S), computed so that 17 of 20 is exactly 17.
int required_count(int seeds) { return static_cast<int>(std::ceil(kRequiredFraction * seeds - 1e-9)); }

// P(Binomial(seeds, p) >= required): the chance that a sampler of true coverage p passes.
double pass_probability(int seeds, int required, double p) {
  if (required <= 0) return 1.0;
  return boost::math::cdf(boost::math::complement(boost::math::binomial(seeds, p), required - 1));
}

SeedOutcome fit_one_seed(const site::Site& site, const bench::FleetPreset& preset, int trucks, int data_seed) {
  SeedOutcome out;
  out.data_seed = data_seed;
  const fleet::SimulatedLog log = bench::simulate_preset(site, preset, trucks, static_cast<std::uint64_t>(data_seed));
  const fleet::MarginalSmc::Options options;  // default, as `ssrfleet fit` runs it
  const auto t0 = std::chrono::steady_clock::now();
  try {
    fleet::MarginalSmc smc(site, options);
    bench::replay_and_rejuvenate(smc, log.records, options.sampler.schedule.final_sweeps);
    out.summary = bench::summarise_hypers(smc.cloud());
  } catch (const std::exception& e) {
    out.error = e.what();
  }
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const fleet::HyperVector truth = preset.truth();
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    out.inside[H] = out.error.empty() && out.summary[H].q025 <= truth[H] && truth[H] <= out.summary[H].q975;
  }
  return out;
}

std::array<int, fleet::kHyperCount> covered_counts(const std::vector<SeedOutcome>& outcomes) {
  std::array<int, fleet::kHyperCount> n{};
  for (const auto& o : outcomes)
    for (int h = 0; h < fleet::kHyperCount; ++h) n[static_cast<std::size_t>(h)] += o.inside[static_cast<std::size_t>(h)];
  return n;
}

// Per hyperparameter over the fits that ran: the mean and rms of (posterior mean - truth) /
// posterior sd. A calibrated posterior gives about 0 and 1; a bias or a too-narrow posterior shows
// here before it shows in a count of 20.
struct ZScores {
  std::array<double, fleet::kHyperCount> mean{}, rms{};
};

ZScores z_scores(const std::vector<SeedOutcome>& outcomes, const fleet::HyperVector& truth) {
  ZScores z;
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    double sum = 0.0, sum2 = 0.0;
    int n = 0;
    for (const auto& o : outcomes) {
      if (!o.error.empty()) continue;
      const double e = (o.summary[H].mean - truth[H]) / o.summary[H].sd;
      sum += e, sum2 += e * e, ++n;
    }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    z.mean[H] = n ? sum / n : nan;
    z.rms[H] = n ? std::sqrt(sum2 / n) : nan;
  }
  return z;
}

bool all_judged_pass(const std::array<int, fleet::kHyperCount>& covered, int required) {
  for (int h = 0; h < fleet::kHyperCount; ++h)
    if (kJudged[static_cast<std::size_t>(h)] && covered[static_cast<std::size_t>(h)] < required) return false;
  return true;
}

int failed_fits(const std::vector<SeedOutcome>& outcomes) {
  int n = 0;
  for (const auto& o : outcomes) n += !o.error.empty();
  return n;
}

nlohmann::json statistics_json(int seeds, int required) {
  const double p_fail = 1.0 - pass_probability(seeds, required, kNominalCoverage);
  return {{"nominal_coverage", kNominalCoverage},
          {"required", required},
          {"p_fail_one_parameter_at_true_coverage_0.95", p_fail},
          {"p_fail_any_of_5_judged_union_bound", std::min(1.0, 5.0 * p_fail)},
          {"p_pass_one_parameter_at_true_coverage_0.90", pass_probability(seeds, required, 0.90)},
          {"p_pass_one_parameter_at_true_coverage_0.85", pass_probability(seeds, required, 0.85)}};
}

nlohmann::json results_json(const Settings& s, const std::vector<SeedOutcome>& outcomes) {
  const int required = required_count(s.seeds);
  const auto covered = covered_counts(outcomes);
  const fleet::HyperVector truth = s.preset.truth();
  const ZScores z = z_scores(outcomes, truth);
  const fleet::MarginalSmc::Options defaults;
  nlohmann::json j;
  j["benchmark"] = "coverage";
  j["started_utc"] = s.started;
  j["written_utc"] = bench::utc_now();
  j["commit"] = s.commit;
  j["nproc"] = s.nproc;
  j["complete"] = static_cast<int>(outcomes.size()) == s.seeds;
  j["load_average_1min"] = {{"before", s.load_before}, {"now", bench::load_average_1min()}};
  j["settings"] = {{"fleet", bench::preset_json(s.preset)},
                   {"trucks", s.trucks},
                   {"data_seeds", {1, s.seeds}},
                   {"smc", {{"options", "MarginalSmc default"},
                            {"particles", defaults.sampler.particles},
                            {"seed", defaults.sampler.seed},
                            {"threads", defaults.sampler.threads},
                            {"final_sweeps", defaults.sampler.schedule.final_sweeps}}},
                   {"interval", "weighted 2.5 % and 97.5 % quantiles (fleet::summarise_cloud)"}};
  j["statistics"] = statistics_json(s.seeds, required);
  nlohmann::json per = nlohmann::json::object();
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    per[std::string(fleet::kHyperNames[h])] = {{"truth", truth[H]},
                                               {"covered", covered[H]},
                                               {"of", static_cast<int>(outcomes.size())},
                                               {"judged", kJudged[H]},
                                               {"pass", kJudged[H] ? nlohmann::json(covered[H] >= required) : nlohmann::json(nullptr)},
                                               {"mean_z", bench::num(z.mean[H])},
                                               {"rms_z", bench::num(z.rms[H])}};
  }
  j["coverage"] = per;
  j["failed_fits"] = failed_fits(outcomes);
  j["verdict"] = static_cast<int>(outcomes.size()) < s.seeds ? "partial"
                                                               : (all_judged_pass(covered, required) ? "PASS" : "FAIL");
  nlohmann::json seeds = nlohmann::json::array();
  for (const auto& o : outcomes) {
    nlohmann::json hyper = nlohmann::json::object();
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const auto& p = o.summary[static_cast<std::size_t>(h)];
      hyper[std::string(fleet::kHyperNames[h])] = {{"mean", p.mean}, {"sd", p.sd}, {"q025", p.q025}, {"q975", p.q975},
                                                   {"inside", o.inside[static_cast<std::size_t>(h)]}};
    }
    seeds.push_back({{"data_seed", o.data_seed},
                     {"wall_s", o.wall_s},
                     {"error", o.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.error)},
                     {"posterior", o.error.empty() ? hyper : nlohmann::json(nullptr)}});
  }
  j["per_seed"] = seeds;
  return j;
}

void write_markdown(std::ostream& f, const Settings& s, const std::vector<SeedOutcome>& outcomes) {
  const int required = required_count(s.seeds);
  const auto covered = covered_counts(outcomes);
  const fleet::HyperVector truth = s.preset.truth();
  const ZScores z = z_scores(outcomes, truth);
  const bool complete = static_cast<int>(outcomes.size()) == s.seeds;
  const double p_fail = 1.0 - pass_probability(s.seeds, required, kNominalCoverage);
  f << "# Coverage benchmark: SMC 95 % intervals against the truth" << (complete ? "" : " (PARTIAL)") << "\n\n";
  f << "Fleet `" << s.preset.name << "`: " << s.preset.description << ", road " << s.preset.road << ", sigma_IF "
    << s.preset.sigma_if << "; " << s.trucks << " trucks; data seeds 1-" << s.seeds
    << " (fleet draw and noise). fleet::MarginalSmc default options, all records absorbed, then rejuvenate("
    << fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps << "); interval = weighted 2.5 % / 97.5 % quantiles. Commit "
    << s.commit << ", nproc " << s.nproc << ", started " << s.started << ", written " << bench::utc_now()
    << ", 1-min load " << fmt(s.load_before, 2) << " before, " << fmt(bench::load_average_1min(), 2) << " now.\n\n";
  f << "Judged: K, Kt, Z, sigma_z, sigma_if, each covered in at least " << required << " of " << s.seeds
    << ". **Verdict: " << (!complete ? "partial" : (all_judged_pass(covered, required) ? "PASS" : "FAIL"))
    << "**. Failed fits (counted as misses): " << failed_fits(outcomes) << ".\n\n";
  f << "Statistics: at true coverage 95 % the count is Binomial(" << s.seeds << ", 0.95): P(count < " << required
    << ") = " << fmt(100.0 * p_fail, 1) << " % for one parameter, up to " << fmt(100.0 * std::min(1.0, 5.0 * p_fail), 1)
    << " % that at least one of the 5 judged fails (union bound). The check is weak the other way: a true coverage "
       "of 90 % passes one parameter with probability "
    << fmt(100.0 * pass_probability(s.seeds, required, 0.90), 0) << " %, of 85 % with "
    << fmt(100.0 * pass_probability(s.seeds, required, 0.85), 0)
    << " %. z = (posterior mean - truth) / posterior sd over the fits: about 0 mean and 1 rms if calibrated.\n\n";
  f << "| parameter | truth | covered | judged | mean z | rms z |\n|---|---|---|---|---|---|\n";
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    f << "| " << fleet::kHyperNames[h] << " | " << fmt_g(truth[H]) << " | " << covered[H] << " / " << outcomes.size()
      << " | " << (kJudged[H] ? (covered[H] >= required ? "PASS" : "FAIL") : "not judged") << " | "
      << fmt(z.mean[H], 2) << " | " << fmt(z.rms[H], 2) << " |\n";
  }
  f << "\n| data seed | fit s | outside its 95 % interval |\n|---|---|---|\n";
  for (const auto& o : outcomes) {
    std::string misses;
    for (int h = 0; h < fleet::kHyperCount; ++h)
      if (!o.inside[static_cast<std::size_t>(h)]) misses += (misses.empty() ? "" : ", ") + std::string(fleet::kHyperNames[h]);
    f << "| " << o.data_seed << " | " << fmt(o.wall_s, 1) << " | "
      << (o.error.empty() ? (misses.empty() ? "-" : misses) : "FIT FAILED: `" + o.error + "`") << " |\n";
  }
}

void write_results(const Settings& s, const std::vector<SeedOutcome>& outcomes) {
  if (!s.json_path.empty()) {
    std::ofstream f = bench::open_results_file(s.json_path);
    f << results_json(s, outcomes).dump(2) << "\n";
  }
  if (!s.md_path.empty()) {
    std::ofstream f = bench::open_results_file(s.md_path);
    write_markdown(f, s, outcomes);
  }
}

void print_progress(const SeedOutcome& o, int seeds) {
  std::cerr << "seed " << o.data_seed << "/" << seeds << ": fit " << fmt(o.wall_s, 1) << " s";
  if (!o.error.empty()) {
    std::cerr << ", FAILED: " << o.error << "\n";
    return;
  }
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    std::cerr << (h ? ", " : "; ") << fleet::kHyperNames[h] << " [" << fmt_g(o.summary[H].q025) << ", "
              << fmt_g(o.summary[H].q975) << "]" << (o.inside[H] ? "" : " MISS");
  }
  std::cerr << " (load " << fmt(bench::load_average_1min(), 2) << ")\n";
}

std::optional<Settings> parse_args(int argc, char** argv, bool* check) {
  Settings s;
  std::string fleet_name = "table1";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--fleet") fleet_name = next();
    else if (a == "--trucks") s.trucks = std::stoi(next());
    else if (a == "--seeds") s.seeds = std::stoi(next());
    else if (a == "--json") s.json_path = next();
    else if (a == "--markdown") s.md_path = next();
    else if (a == "--commit") s.commit = next();
    else if (a == "--check") *check = true;
    else return std::nullopt;
  }
  const std::optional<bench::FleetPreset> preset = bench::find_fleet_preset(fleet_name);
  if (!preset || s.trucks < 1 || s.seeds < 1) return std::nullopt;
  s.preset = *preset;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  bool check = false;
  std::optional<Settings> settings = parse_args(argc, argv, &check);
  if (!settings) {
    std::cerr << "usage: coverage_benchmark [--fleet " << bench::fleet_preset_names()
              << "] [--trucks 1000] [--seeds 20] [--json FILE]\n"
                 "                          [--markdown FILE] [--commit HASH] [--check]\n";
    return 2;
  }
  Settings& s = *settings;
  if (s.commit.empty()) s.commit = bench::run_command("git rev-parse --short HEAD 2>/dev/null");
  s.nproc = sysconf(_SC_NPROCESSORS_ONLN);
  s.started = bench::utc_now();
  s.load_before = bench::load_average_1min();

  const site::Site site(road::preset_surface(s.preset.road), site::SiteOptions{});
  std::vector<SeedOutcome> outcomes;
  for (int seed = 1; seed <= s.seeds; ++seed) {
    outcomes.push_back(fit_one_seed(site, s.preset, s.trucks, seed));
    print_progress(outcomes.back(), s.seeds);
    write_results(s, outcomes);
  }
  const int required = required_count(s.seeds);
  const auto covered = covered_counts(outcomes);
  std::cout << "coverage, fleet " << s.preset.name << ", " << s.trucks << " trucks, " << s.seeds
            << " data seeds (required " << required << " for the judged):\n";
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto H = static_cast<std::size_t>(h);
    std::cout << "  " << fleet::kHyperNames[h] << " " << covered[H] << "/" << s.seeds
              << (kJudged[H] ? (covered[H] >= required ? " PASS" : " FAIL") : " (not judged)") << "\n";
  }
  std::cout << "  failed fits " << failed_fits(outcomes) << std::endl;
  return check && !all_judged_pass(covered, required) ? 1 : 0;
}
