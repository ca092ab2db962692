// Simulation-based calibration of the base model (Talts, Betancourt, Simpson,
// Vehtari & Gelman 2018, arXiv:1804.06788, Algorithm 1). For r = 1, ..., R:
//   1. θ_r uniform on the SBC prior box (sbc_prior.hpp), from stream r of a fixed generator;
//   2. a fleet of N trucks from θ_r and its WIM log on AS1 with noise σ_IF from θ_r (data seed r);
//   3. the fit `ssrfleet fit` makes: fleet::MarginalSmc with default options (particles, final
//      sweeps, moves) except its prior, set to the same box, and SMC seed r; every record
//      absorbed, then rejuvenate(final_sweeps);
//   4. L draws from the weighted cloud by systematic resampling (stream r of another generator);
//   5. the rank of each true hyperparameter among its L draws (util/rank_histogram.hpp).
// If the fit is calibrated, each hyperparameter's R ranks are uniform on {0, ..., L}; the rank
// histograms (B bins) are judged by a χ² test, and the check fails if any p <= 0.01.
//
// Why L draws by systematic resampling are near-independent: after the final sweeps the particles
// have each been moved many times by independence proposals (MarginalSmc::Options), and the weights
// are near equal, so no particle carries more than 1/L of the weight and systematic resampling
// takes L different particles spread over the cloud (a thinning of the 1,024 by about 10). The
// harness checks it: it counts distinct θ among the draws, reports the weight ESS, and measures
// the cloud's equivalent ESS (the first K replications refitted with S SMC seeds: posterior sd²
// over the pooled scatter² of the posterior means), which should well exceed L.
//
//   sbc_benchmark [--replications 200] [--trucks 50] [--draws 99] [--bins 10]
//                 [--ess-replications 10] [--ess-seeds 3] [--json FILE] [--markdown FILE]
//                 [--plot STEM] [--commit HASH] [--check]
// --plot STEM writes STEM-histograms.csv, STEM.gp, STEM.png, STEM.svg. --check: exit status 1 if a
// histogram fails (p <= 0.01) or a fit failed. Progress on stderr; the reports are rewritten after
// every replication (marked partial until the last).
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <exception>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "fleet/marginal_smc.hpp"
#include "fleet/posterior_summary.hpp"
#include "report_format.hpp"
#include "road/surface_presets.hpp"
#include "run_info.hpp"
#include "sbc_prior.hpp"
#include "sbc_report.hpp"
#include "smc/resampling.hpp"
#include "smc/rng.hpp"
#include "util/rank_histogram.hpp"

using namespace ssrfleet;
using bench::fmt;
using bench::sbc::HyperArray;
using bench::sbc::Replication;
using bench::sbc::Settings;

namespace {

constexpr std::uint64_t kThetaStreams = 0x5BC;  // θ_r: stream r
constexpr std::uint64_t kDrawStreams = 0xD5A;   // the L draws of replication r: stream r
// The independence refits use SMC seeds r + s · kRefitSeedStride, s = 1, ..., S − 1.
constexpr std::uint64_t kRefitSeedStride = 1000003;

struct Fit {
  fleet::PosteriorCloud cloud;
  double acceptance = 0.0;
  double wall_s = 0.0;
};

Fit fit_log(const site::Site& site, const fleet::PriorBounds& prior, const std::vector<records::WimRecord>& records,
            std::uint64_t smc_seed) {
  fleet::MarginalSmc::Options options;  // default, as `ssrfleet fit` runs it
  options.target.prior = prior;
  options.sampler.seed = smc_seed;
  const auto t0 = std::chrono::steady_clock::now();
  fleet::MarginalSmc smc(site, options);
  for (std::size_t t = 0; t < records.size(); ++t) {
    smc.prepare(records, t);  // as fleet::replay (ssrfleet fit) does
    smc.absorb(records[t]);
  }
  const smc::MhSummary final_moves = smc.rejuvenate(options.sampler.schedule.final_sweeps);
  Fit fit;
  fit.cloud = smc.cloud();
  for (double a : final_moves.acceptance) fit.acceptance += a / static_cast<double>(final_moves.acceptance.size());
  fit.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return fit;
}

void summarise(const fleet::PosteriorCloud& cloud, HyperArray* mean, HyperArray* sd) {
  const std::vector<fleet::ParameterSummary> rows = fleet::summarise_cloud(cloud);
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    (*mean)[static_cast<std::size_t>(j)] = rows.at(static_cast<std::size_t>(j)).mean;
    (*sd)[static_cast<std::size_t>(j)] = rows.at(static_cast<std::size_t>(j)).sd;
  }
}

fleet::HyperVector theta_of_replication(const fleet::PriorBounds& prior, int r) {
  smc::Rng rng = smc::RngFactory(kThetaStreams).stream(static_cast<std::uint64_t>(r));
  return bench::draw_from_box(prior, rng);
}

Replication run_replication(const site::Site& site, const Settings& s, int r) {
  Replication out;
  out.index = r;
  out.truth = theta_of_replication(s.prior, r);
  const fleet::SimulatedLog log = bench::simulate_sbc_log(site, out.truth, s.trucks, static_cast<std::uint64_t>(r));
  out.lift_offs = log.lift_offs;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    const Fit fit = fit_log(site, s.prior, log.records, static_cast<std::uint64_t>(r));
    out.cloud_ess = fit.cloud.weight_ess;
    out.final_acceptance = fit.acceptance;
    summarise(fit.cloud, &out.post_mean, &out.post_sd);
    smc::Rng rng = smc::RngFactory(kDrawStreams).stream(static_cast<std::uint64_t>(r));
    const std::vector<Eigen::Index> picked = smc::systematic_resampling(fit.cloud.weights, s.draws, rng);
    std::set<std::vector<double>> distinct;
    for (Eigen::Index p : picked) {
      const Eigen::VectorXd th = fit.cloud.theta.col(p);
      distinct.insert(std::vector<double>(th.data(), th.data() + th.size()));
    }
    out.distinct_draws = static_cast<int>(distinct.size());
    for (int j = 0; j < fleet::kHyperCount; ++j) {
      std::vector<double> draws;
      draws.reserve(picked.size());
      for (Eigen::Index p : picked) draws.push_back(fit.cloud.theta(j, p));
      out.rank[static_cast<std::size_t>(j)] = sbc_rank(out.truth[static_cast<std::size_t>(j)], draws);
    }
  } catch (const std::exception& e) {
    out.error = e.what();
  }
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

// Replications 1..K refitted with S − 1 more SMC seeds (the original fit is seed 1 of S).
bench::sbc::IndependenceCheck independence_check(const site::Site& site, const Settings& s,
                                                 const std::vector<Replication>& reps) {
  std::vector<std::vector<HyperArray>> means, sds;
  int failed = 0;
  for (int k = 0; k < s.ess_replications && k < static_cast<int>(reps.size()); ++k) {
    const Replication& rep = reps[static_cast<std::size_t>(k)];
    if (!rep.error.empty()) continue;
    const fleet::SimulatedLog log =
        bench::simulate_sbc_log(site, rep.truth, s.trucks, static_cast<std::uint64_t>(rep.index));
    std::vector<HyperArray> m{rep.post_mean}, d{rep.post_sd};
    for (int seed = 1; seed < s.ess_seeds; ++seed) {
      try {
        const Fit fit = fit_log(site, s.prior, log.records,
                                static_cast<std::uint64_t>(rep.index) + static_cast<std::uint64_t>(seed) * kRefitSeedStride);
        HyperArray mean{}, sd{};
        summarise(fit.cloud, &mean, &sd);
        m.push_back(mean), d.push_back(sd);
      } catch (const std::exception& e) {
        ++failed;
        std::cerr << "independence refit of replication " << rep.index << " failed: " << e.what() << "\n";
      }
    }
    means.push_back(m), sds.push_back(d);
    std::cerr << "independence check: replication " << rep.index << " refitted with " << m.size() - 1
              << " more seeds\n";
  }
  bench::sbc::IndependenceCheck c = bench::sbc::pooled_equivalent_ess(means, sds);
  c.failed = failed;
  return c;
}

void write_reports(const Settings& s, const std::vector<Replication>& reps, const bench::sbc::IndependenceCheck& ind) {
  if (!s.json_path.empty()) {
    std::ofstream f = bench::open_results_file(s.json_path);
    f << bench::sbc::results_json(s, reps, ind).dump(2) << "\n";
  }
  if (!s.md_path.empty()) {
    std::ofstream f = bench::open_results_file(s.md_path);
    bench::sbc::write_markdown(f, s, reps, ind);
  }
}

void print_progress(const Settings& s, const Replication& r) {
  std::cerr << "replication " << r.index << "/" << s.replications << ": fit " << fmt(r.wall_s, 2) << " s";
  if (!r.error.empty()) {
    std::cerr << ", FAILED: " << r.error << "\n";
    return;
  }
  std::cerr << ", ESS " << fmt(r.cloud_ess, 0) << ", acceptance " << fmt(r.final_acceptance, 2) << ", distinct "
            << r.distinct_draws << "; ranks";
  for (int j = 0; j < fleet::kHyperCount; ++j)
    std::cerr << " " << fleet::kHyperNames[j] << " " << r.rank[static_cast<std::size_t>(j)];
  std::cerr << " (load " << fmt(bench::load_average_1min(), 2) << ")\n";
}

std::optional<Settings> parse_args(int argc, char** argv, bool* check) {
  Settings s;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--replications") s.replications = std::stoi(next());
    else if (a == "--trucks") s.trucks = std::stoi(next());
    else if (a == "--draws") s.draws = std::stoi(next());
    else if (a == "--bins") s.bins = std::stoi(next());
    else if (a == "--ess-replications") s.ess_replications = std::stoi(next());
    else if (a == "--ess-seeds") s.ess_seeds = std::stoi(next());
    else if (a == "--json") s.json_path = next();
    else if (a == "--markdown") s.md_path = next();
    else if (a == "--plot") s.plot_stem = next();
    else if (a == "--commit") s.commit = next();
    else if (a == "--check") *check = true;
    else return std::nullopt;
  }
  if (s.replications < 1 || s.trucks < 1 || s.draws < 1 || s.bins < 2 || (s.draws + 1) % s.bins != 0 ||
      s.ess_replications < 0 || s.ess_seeds < 1)
    return std::nullopt;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  bool check = false;
  std::optional<Settings> settings = parse_args(argc, argv, &check);
  if (!settings) {
    std::cerr << "usage: sbc_benchmark [--replications 200] [--trucks 50] [--draws 99] [--bins 10 (must divide draws + 1)]\n"
                 "                     [--ess-replications 10] [--ess-seeds 3] [--json FILE] [--markdown FILE]\n"
                 "                     [--plot STEM] [--commit HASH] [--check]\n";
    return 2;
  }
  Settings& s = *settings;
  const fleet::MarginalSmc::Options defaults;
  s.particles = static_cast<int>(defaults.sampler.particles);
  s.final_sweeps = defaults.sampler.schedule.final_sweeps;
  s.prior = bench::sbc_prior();
  s.road = "AS1";
  if (s.commit.empty()) s.commit = bench::run_command("git rev-parse --short HEAD 2>/dev/null");
  s.nproc = sysconf(_SC_NPROCESSORS_ONLN);
  s.started = bench::utc_now();
  s.load_before = bench::load_average_1min();
  std::cerr << "SBC prior: worst-corner P(k < 0) + P(k_t < 0) per truck "
            << bench::worst_negative_stiffness_probability(s.prior) << "\n";

  const site::Site site(road::preset_surface(s.road), site::SiteOptions{});
  std::vector<Replication> reps;
  bench::sbc::IndependenceCheck independence;
  for (int r = 1; r <= s.replications; ++r) {
    reps.push_back(run_replication(site, s, r));
    print_progress(s, reps.back());
    write_reports(s, reps, independence);
  }
  independence = independence_check(site, s, reps);
  write_reports(s, reps, independence);
  if (!s.plot_stem.empty()) {
    const std::string problem = bench::sbc::write_plot(s, reps);
    if (!problem.empty()) std::cerr << "warning: " << problem << "\n";
  }

  const bench::sbc::Histograms h = bench::sbc::histograms(s, reps);
  std::cout << "SBC, " << s.replications << " replications of " << s.trucks << " trucks, L = " << s.draws
            << ", B = " << s.bins << " (pass at p > " << bench::sbc::kPassP << "):\n";
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto J = static_cast<std::size_t>(j);
    std::cout << "  " << fleet::kHyperNames[j] << " chi2 " << fmt(h.test[J].statistic, 2) << ", p "
              << fmt(h.test[J].p_value, 4) << (h.test[J].p_value > bench::sbc::kPassP ? " pass" : " FAIL") << "\n";
  }
  std::cout << "  failed fits " << bench::sbc::failed_fits(reps) << "; verdict "
            << bench::sbc::verdict(s, reps, h) << std::endl;
  return check && !bench::sbc::passes(s, reps, h) ? 1 : 0;
}
