// What the SBC benchmark (sbc_benchmark.cpp) keeps and writes: one record per replication, the
// rank histograms with their χ² tests, and the reports: JSON (data), Markdown (for people) and a
// gnuplot figure of the 7 histograms against the 99 % band of a uniform histogram.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <boost/math/distributions/chi_squared.hpp>
#include <nlohmann/json.hpp>

#include "io/gnuplot_runner.hpp"
#include "model/fleet_model.hpp"
#include "report_format.hpp"
#include "run_info.hpp"
#include "util/rank_histogram.hpp"

namespace ssrfleet::bench::sbc {

using HyperArray = std::array<double, fleet::kHyperCount>;
using HyperInts = std::array<int, fleet::kHyperCount>;

// The 99 % band of each bin's count under uniform ranks (the figure's grey band).
inline constexpr double kBandLevel = 0.99;
// A hyperparameter's histogram fails at p <= this.
inline constexpr double kPassP = 0.01;

struct Settings {
  int replications = 200, trucks = 50, draws = 99, bins = 10;
  int ess_replications = 10, ess_seeds = 3;  // the independence check (sbc_benchmark.cpp)
  int particles = 0, final_sweeps = 0;       // the fit's, from MarginalSmc::Options
  fleet::PriorBounds prior;
  std::string road, json_path, md_path, plot_stem, commit, started;
  long nproc = 0;
  double load_before = 0.0;
};

struct Replication {
  int index = 0;              // r: θ stream, data seed and SMC seed
  fleet::HyperVector truth{};
  double wall_s = 0.0;
  std::string error;          // what the fit threw ("" = it ran)
  HyperInts rank{};
  HyperArray post_mean{}, post_sd{};
  double cloud_ess = 0.0;     // the weights' ESS after the final sweeps (of `particles`)
  double final_acceptance = 0.0;  // mean acceptance of the final sweeps' moves
  int distinct_draws = 0;     // distinct θ among the L draws
  int lift_offs = 0;          // simulated trucks whose tyre left the road somewhere
};

// The independence check: the first K replications refitted with other SMC seeds. The scatter of
// a replication's posterior means over seeds, pooled over replications, against the posterior sd
// gives the cloud's equivalent ESS (seed_scatter.hpp's idea), which the L draws must not exceed by
// much for them to act as independent draws (Talts et al. §4.1: thin to about the ESS).
struct IndependenceCheck {
  int replications = 0, seeds = 0, failed = 0;
  HyperArray equivalent_ess{}, ess_lo90{}, ess_hi90{};
};

inline IndependenceCheck pooled_equivalent_ess(const std::vector<std::vector<HyperArray>>& means,
                                               const std::vector<std::vector<HyperArray>>& sds) {
  IndependenceCheck c;
  c.replications = static_cast<int>(means.size());
  c.seeds = means.empty() ? 0 : static_cast<int>(means.front().size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  c.equivalent_ess.fill(nan), c.ess_lo90.fill(nan), c.ess_hi90.fill(nan);
  double dof = 0.0;
  for (const auto& m : means) dof += m.size() > 1 ? static_cast<double>(m.size()) - 1.0 : 0.0;
  if (dof < 1.0) return c;
  const boost::math::chi_squared chi2(dof);
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto J = static_cast<std::size_t>(j);
    double ss = 0.0, var = 0.0;
    int n = 0;
    for (std::size_t r = 0; r < means.size(); ++r) {
      double mean = 0.0;
      for (const auto& m : means[r]) mean += m[J] / static_cast<double>(means[r].size());
      for (std::size_t s = 0; s < means[r].size(); ++s) {
        ss += (means[r][s][J] - mean) * (means[r][s][J] - mean);
        var += sds[r][s][J] * sds[r][s][J], ++n;
      }
    }
    // scatter² ~ σ²/E · χ²(dof)/dof, so E = mean(sd²) / scatter², known to a χ²(dof)/dof factor.
    const double scatter2 = ss / dof;
    c.equivalent_ess[J] = var / n / scatter2;
    c.ess_lo90[J] = c.equivalent_ess[J] * boost::math::quantile(chi2, 0.05) / dof;
    c.ess_hi90[J] = c.equivalent_ess[J] * boost::math::quantile(chi2, 0.95) / dof;
  }
  return c;
}

struct Histograms {
  std::array<std::vector<int>, fleet::kHyperCount> counts;
  std::array<ChiSquareUniformity, fleet::kHyperCount> test{};
  CountInterval band{};
  int used = 0;  // replications whose fit ran
};

inline Histograms histograms(const Settings& s, const std::vector<Replication>& reps) {
  Histograms h;
  std::array<std::vector<int>, fleet::kHyperCount> ranks;
  for (const auto& r : reps) {
    if (!r.error.empty()) continue;
    ++h.used;
    for (int j = 0; j < fleet::kHyperCount; ++j) ranks[static_cast<std::size_t>(j)].push_back(r.rank[static_cast<std::size_t>(j)]);
  }
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto J = static_cast<std::size_t>(j);
    h.counts[J] = rank_histogram(ranks[J], s.draws, s.bins);
    if (h.used > 0) h.test[J] = chi_square_uniformity(h.counts[J]);
  }
  h.band = binomial_central_interval(h.used, 1.0 / s.bins, kBandLevel);
  return h;
}

inline int failed_fits(const std::vector<Replication>& reps) {
  return static_cast<int>(std::count_if(reps.begin(), reps.end(), [](const Replication& r) { return !r.error.empty(); }));
}

// PASS: every replication ran, and every histogram's p > 0.01. A failed fit leaves a hole in the
// ranks that need not be at random, so it fails the check rather than being dropped.
inline bool passes(const Settings& s, const std::vector<Replication>& reps, const Histograms& h) {
  if (static_cast<int>(reps.size()) < s.replications || failed_fits(reps) > 0) return false;
  for (const auto& t : h.test)
    if (!(t.p_value > kPassP)) return false;
  return true;
}

inline std::string verdict(const Settings& s, const std::vector<Replication>& reps, const Histograms& h) {
  if (static_cast<int>(reps.size()) < s.replications) return "partial";
  return passes(s, reps, h) ? "PASS" : "FAIL";
}

// Per hyperparameter over the fits that ran: mean and rms of (posterior mean − truth) / posterior sd
// (about 0 and 1 for a calibrated posterior), and the mean posterior contraction 1 − sd² / prior
// variance (Talts et al. §5: how much the data teach, so a flat histogram is not a prior echoed).
struct Scores {
  HyperArray mean_z{}, rms_z{}, contraction{};
};

inline Scores scores(const Settings& s, const std::vector<Replication>& reps) {
  Scores out;
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const auto J = static_cast<std::size_t>(j);
    const double width = s.prior.hi[J] - s.prior.lo[J], prior_var = width * width / 12.0;
    double z = 0.0, z2 = 0.0, c = 0.0;
    int n = 0;
    for (const auto& r : reps) {
      if (!r.error.empty()) continue;
      const double e = (r.post_mean[J] - r.truth[J]) / r.post_sd[J];
      z += e, z2 += e * e, c += 1.0 - r.post_sd[J] * r.post_sd[J] / prior_var, ++n;
    }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    out.mean_z[J] = n ? z / n : nan;
    out.rms_z[J] = n ? std::sqrt(z2 / n) : nan;
    out.contraction[J] = n ? c / n : nan;
  }
  return out;
}

inline nlohmann::json results_json(const Settings& s, const std::vector<Replication>& reps,
                                   const IndependenceCheck& ind) {
  const Histograms h = histograms(s, reps);
  const Scores sc = scores(s, reps);
  nlohmann::json j;
  j["benchmark"] = "sbc";
  j["started_utc"] = s.started;
  j["written_utc"] = utc_now();
  j["commit"] = s.commit;
  j["nproc"] = s.nproc;
  j["complete"] = static_cast<int>(reps.size()) == s.replications;
  j["load_average_1min"] = {{"before", s.load_before}, {"now", load_average_1min()}};
  nlohmann::json prior = nlohmann::json::object();
  for (int k = 0; k < fleet::kHyperCount; ++k)
    prior[std::string(fleet::kHyperNames[k])] = {s.prior.lo[static_cast<std::size_t>(k)], s.prior.hi[static_cast<std::size_t>(k)]};
  j["settings"] = {{"replications", s.replications},
                   {"trucks", s.trucks},
                   {"road", s.road},
                   {"posterior_draws_L", s.draws},
                   {"bins_B", s.bins},
                   {"prior_uniform_box", prior},
                   {"smc", {{"options", "MarginalSmc default, target.prior = the SBC box"},
                            {"particles", s.particles},
                            {"final_sweeps", s.final_sweeps},
                            {"seed", "replication index r"}}},
                   {"draws", "systematic resampling of L particles from the weighted cloud after the final sweeps"},
                   {"seeds", "theta: stream r of RngFactory(0x5BC); data (fleet and noise): r; SMC: r; draws: stream r "
                             "of RngFactory(0xD5A)"}};
  nlohmann::json per = nlohmann::json::object();
  for (int k = 0; k < fleet::kHyperCount; ++k) {
    const auto K = static_cast<std::size_t>(k);
    per[std::string(fleet::kHyperNames[k])] = {{"counts", h.counts[K]},
                                               {"chi2", h.test[K].statistic},
                                               {"dof", h.test[K].degrees_of_freedom},
                                               {"p_value", h.test[K].p_value},
                                               {"pass", h.test[K].p_value > kPassP},
                                               {"mean_z", num(sc.mean_z[K])},
                                               {"rms_z", num(sc.rms_z[K])},
                                               {"mean_contraction", num(sc.contraction[K])}};
  }
  j["histograms"] = per;
  j["band_99"] = {{"lo", h.band.lo}, {"hi", h.band.hi}, {"expected", static_cast<double>(h.used) / s.bins}};
  j["independence_check"] = {{"replications", ind.replications},
                             {"seeds_each", ind.seeds},
                             {"failed_fits", ind.failed},
                             {"equivalent_ess", hyper_json(ind.equivalent_ess)},
                             {"equivalent_ess_lo90", hyper_json(ind.ess_lo90)},
                             {"equivalent_ess_hi90", hyper_json(ind.ess_hi90)}};
  j["failed_fits"] = failed_fits(reps);
  j["verdict"] = verdict(s, reps, h);
  double total = 0.0;
  for (const auto& r : reps) total += r.wall_s;
  j["fit_wall_s"] = {{"total", total}, {"mean", reps.empty() ? 0.0 : total / static_cast<double>(reps.size())}};
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : reps) {
    rows.push_back({{"r", r.index},
                    {"truth", hyper_json(r.truth)},
                    {"wall_s", r.wall_s},
                    {"error", r.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.error)},
                    {"rank", hyper_json(r.rank)},
                    {"posterior_mean", hyper_json(r.post_mean)},
                    {"posterior_sd", hyper_json(r.post_sd)},
                    {"cloud_ess", r.cloud_ess},
                    {"final_acceptance", r.final_acceptance},
                    {"distinct_draws", r.distinct_draws},
                    {"lift_offs", r.lift_offs}});
  }
  j["per_replication"] = rows;
  return j;
}

inline void write_markdown(std::ostream& f, const Settings& s, const std::vector<Replication>& reps,
                           const IndependenceCheck& ind) {
  const Histograms h = histograms(s, reps);
  const Scores sc = scores(s, reps);
  const bool complete = static_cast<int>(reps.size()) == s.replications;
  double total = 0.0, min_ess = HUGE_VAL, min_acc = HUGE_VAL;
  int min_distinct = s.draws, lift_offs = 0;
  for (const auto& r : reps) {
    total += r.wall_s;
    if (!r.error.empty()) continue;
    min_ess = std::min(min_ess, r.cloud_ess), min_acc = std::min(min_acc, r.final_acceptance);
    min_distinct = std::min(min_distinct, r.distinct_draws), lift_offs += r.lift_offs;
  }
  f << "# Simulation-based calibration of the base model" << (complete ? "" : " (PARTIAL)") << "\n\n";
  f << "Talts et al. (2018): R = " << reps.size() << " of " << s.replications << " replications; each draws θ from "
    << "the SBC prior, a fleet of N = " << s.trucks << " trucks from θ and its WIM log on " << s.road
    << " (noise σ_IF from θ), fits it with fleet::MarginalSmc (default options: " << s.particles << " particles, "
    << s.final_sweeps << " final sweeps; its prior set to the SBC prior), takes L = " << s.draws
    << " draws by systematic resampling of the weighted cloud, and ranks each true hyperparameter among them "
    << "(rank = #{draws < truth}, 0-" << s.draws << "). Histograms of B = " << s.bins << " bins of "
    << (s.draws + 1) / s.bins << " rank values; χ² test of uniformity with " << s.bins - 1
    << " degrees of freedom; pass at p > " << kPassP << " for each of the 7. Commit " << s.commit << ", nproc "
    << s.nproc << ", started " << s.started << ", written " << utc_now() << ", 1-min load " << fmt(s.load_before, 2)
    << " before, " << fmt(load_average_1min(), 2) << " now.\n\n";
  f << "**Verdict: " << verdict(s, reps, h) << "** (failed fits: " << failed_fits(reps)
    << "). For a calibrated sampler each test fails with probability 1 %, so at least one of the 7 fails about "
    << fmt(100.0 * (1.0 - std::pow(1.0 - kPassP, fleet::kHyperCount)), 1)
    << " % of the time if they were independent.\n\n";
  f << "SBC prior (uniform box; both the simulator's θ and the fit's prior):\n\n| | ";
  for (int k = 0; k < fleet::kHyperCount; ++k) f << fleet::kHyperNames[k] << " | ";
  f << "\n|---|---|---|---|---|---|---|---|\n| lo | ";
  for (int k = 0; k < fleet::kHyperCount; ++k) f << fmt_g(s.prior.lo[static_cast<std::size_t>(k)]) << " | ";
  f << "\n| hi | ";
  for (int k = 0; k < fleet::kHyperCount; ++k) f << fmt_g(s.prior.hi[static_cast<std::size_t>(k)]) << " | ";
  f << "\n\n| parameter | counts per bin (expected " << fmt(static_cast<double>(h.used) / s.bins, 1) << ", 99 % band "
    << h.band.lo << "-" << h.band.hi << ") | χ² | p | | mean z | rms z | contraction |\n|---|---|---|---|---|---|---|---|\n";
  for (int k = 0; k < fleet::kHyperCount; ++k) {
    const auto K = static_cast<std::size_t>(k);
    std::string counts;
    for (int c : h.counts[K]) {
      if (!counts.empty()) counts += ' ';
      counts += std::to_string(c);
    }
    f << "| " << fleet::kHyperNames[k] << " | " << counts << " | " << fmt(h.test[K].statistic, 2) << " | "
      << fmt(h.test[K].p_value, 3) << " | " << (h.test[K].p_value > kPassP ? "pass" : "FAIL") << " | "
      << fmt(sc.mean_z[K], 2) << " | " << fmt(sc.rms_z[K], 2) << " | " << fmt(sc.contraction[K], 2) << " |\n";
  }
  f << "\nz = (posterior mean − truth) / posterior sd (about 0 mean, 1 rms if calibrated); contraction = 1 − "
       "posterior variance / prior variance, mean over replications.\n\n";
  f << "Independence of the L draws: smallest weight ESS of a cloud after the final sweeps " << fmt(min_ess, 0)
    << " of " << s.particles << "; smallest mean acceptance of the final sweeps " << fmt(min_acc, 2)
    << "; fewest distinct θ among the L = " << s.draws << " draws " << min_distinct << ". Equivalent ESS of the cloud "
    << "(replications 1-" << ind.replications << " each fitted with " << ind.seeds
    << " SMC seeds, the run's and " << ind.seeds - 1 << " more; posterior sd² over the pooled scatter² of the posterior means; 90 % interval; failed "
       "refits: "
    << ind.failed << "):\n\n| | ";
  for (int k = 0; k < fleet::kHyperCount; ++k) f << fleet::kHyperNames[k] << " | ";
  f << "\n|---|---|---|---|---|---|---|---|\n| ESS | ";
  for (int k = 0; k < fleet::kHyperCount; ++k) {
    const auto K = static_cast<std::size_t>(k);
    f << fmt(ind.equivalent_ess[K], 0) << " (" << fmt(ind.ess_lo90[K], 0) << "-" << fmt(ind.ess_hi90[K], 0) << ") | ";
  }
  f << "\n\nSimulated trucks that lifted a tyre somewhere: " << lift_offs << ". Fit time: " << fmt(total, 0)
    << " s in all, " << fmt(reps.empty() ? 0.0 : total / static_cast<double>(reps.size()), 2)
    << " s per replication (independence refits not included).\n";
}

// The figure: a panel per hyperparameter, its histogram as boxes over rank / (L + 1), the 99 %
// band of a uniform histogram in grey, the expected count dashed. Writes STEM-histograms.csv,
// STEM.gp and (if gnuplot runs) STEM.png and STEM.svg. Returns "" or what went wrong.
inline std::string write_plot(const Settings& s, const std::vector<Replication>& reps) {
  const Histograms h = histograms(s, reps);
  const std::filesystem::path stem(s.plot_stem);
  const std::string dir = stem.parent_path().empty() ? "." : stem.parent_path().string();
  const std::string name = stem.filename().string(), csv = name + "-histograms.csv";
  {
    std::ofstream f = open_results_file((std::filesystem::path(dir) / csv).string());
    f << "rank_fraction";
    for (int k = 0; k < fleet::kHyperCount; ++k) f << "," << fleet::kHyperNames[k];
    f << "\n";
    for (int b = 0; b < s.bins; ++b) {
      f << (b + 0.5) / s.bins;
      for (int k = 0; k < fleet::kHyperCount; ++k) f << "," << h.counts[static_cast<std::size_t>(k)][static_cast<std::size_t>(b)];
      f << "\n";
    }
  }
  static const std::array<const char*, fleet::kHyperCount> titles = {
      "K", "{/Symbol s}_k", "K_t", "{/Symbol s}_{kt}", "Z", "{/Symbol s}_z", "{/Symbol s}_{IF}"};
  int ymax = h.band.hi;
  for (const auto& c : h.counts) ymax = std::max(ymax, *std::max_element(c.begin(), c.end()));
  std::ostringstream body;
  body << "set multiplot layout 2,4 title 'SBC rank histograms: R = " << h.used << ", N = " << s.trucks
       << " trucks, L = " << s.draws << " draws, B = " << s.bins << " bins; grey: 99 % band of a uniform histogram'\n"
       << "set xrange [0:1]\nset yrange [0:" << ymax + 5 << "]\nset xtics 0.5\nset style fill solid 0.6 border -1\n"
       << "set boxwidth " << 0.9 / s.bins << "\nunset key\nset xlabel 'rank / (L + 1)'\n";
  for (int k = 0; k < fleet::kHyperCount; ++k) {
    const auto K = static_cast<std::size_t>(k);
    body << "set title \"" << titles[K] << "  ({/Symbol c}^2 p = " << fmt(h.test[K].p_value, 3) << ")\"\n"
         << "plot '+' using 1:(" << h.band.lo << "):(" << h.band.hi << ") with filledcurves lc rgb '#d9d9d9', '" << csv
         << "' skip 1 using 1:" << k + 2 << " with boxes lc rgb '#1f77b4', " << static_cast<double>(h.used) / s.bins
         << " with lines dt 2 lc rgb 'black'\n";
  }
  body << "unset multiplot\n";
  std::ofstream(std::filesystem::path(dir) / (name + ".gp")) << io::png_and_svg_script(name, body.str(), 1400, 720);
  if (!io::gnuplot_available()) return "gnuplot not found: run `gnuplot " + name + ".gp` in " + dir;
  const std::vector<std::string> failed = io::run_gnuplot(dir, {io::PlotScript{name, ""}});
  return failed.empty() ? "" : "gnuplot failed: see " + dir + "/" + name + ".gnuplot.log";
}

}  // namespace ssrfleet::bench::sbc
