// The reproduction across seeds and noise levels: runs reproduce::run (the
// code behind `ssrfleet reproduce`, plots off) for seeds 1..S at each sigma_IF, and reports per
// hyperparameter the bias and RMSE of the posterior mean and the coverage of the 95 % intervals
// over seeds; the prediction coverage (Figs. 7, 8, 9); the largest AS2/AS3 mean difference; and
// the wall time. Writes a JSON and a Markdown report.
//
//   reproduce_benchmark [--seeds 20] [--noise 0.005,0.02,0.05] [--stress] [--trucks 100]
//                       [--particles 1024] [--threads 0] [--work DIR] [--json FILE] [--markdown FILE]
// --stress adds the seed's literal variance 0.2 (sigma_IF = sqrt(0.2) = 0.447).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/fleet_model.hpp"
#include "reproduce/paper_reproduction.hpp"

using namespace ssrfleet;

int main(int argc, char** argv) {
  int seeds = 20, trucks = 100, particles = 1024, threads = 0;
  std::vector<double> noises = {0.005, 0.02, 0.05};
  std::string work = "reproduce-harness", json_path, md_path;
  bool stress = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--seeds") seeds = std::stoi(next());
    else if (a == "--trucks") trucks = std::stoi(next());
    else if (a == "--particles") particles = std::stoi(next());
    else if (a == "--threads") threads = std::stoi(next());
    else if (a == "--work") work = next();
    else if (a == "--json") json_path = next();
    else if (a == "--markdown") md_path = next();
    else if (a == "--stress") stress = true;
    else if (a == "--noise") {
      noises.clear();
      std::stringstream ss(next());
      std::string item;
      while (std::getline(ss, item, ',')) noises.push_back(std::stod(item));
    } else {
      std::cerr << "usage: reproduce_benchmark [--seeds 20] [--noise 0.005,0.02,0.05] [--stress] [--trucks 100] "
                   "[--particles 1024] [--threads 0] [--work DIR] [--json FILE] [--markdown FILE]\n";
      return a == "--help" || a == "-h" ? 0 : 64;
    }
  }
  if (stress) noises.push_back(std::sqrt(0.2));

  nlohmann::json report;
  report["config"] = {{"seeds", seeds}, {"trucks", trucks}, {"particles", particles}, {"threads", threads}};
  std::ostringstream md;
  md << "# reproduce harness: " << seeds << " seeds, " << trucks << " trucks, " << particles << " particles\n\n";
  for (double noise : noises) {
    std::vector<reproduce::Result> runs;
    std::vector<std::string> failures;
    for (int s = 1; s <= seeds; ++s) {
      reproduce::Options o;
      o.seed = static_cast<std::uint64_t>(s);
      o.trucks = trucks;
      o.particles = particles;
      o.threads = threads;
      o.noise_sd = noise;
      o.plots = false;
      std::ostringstream dir;
      dir << work << "/noise-" << noise << "/seed-" << s;
      o.out_dir = dir.str();
      try {
        runs.push_back(reproduce::run(o));
      } catch (const std::exception& e) {
        failures.push_back("seed " + std::to_string(s) + ": " + e.what());
        std::cerr << "harness: sigma_IF " << std::setprecision(4) << noise << " seed " << s << ": FAILED: " << e.what() << "\n";
        continue;
      }
      const auto& r = runs.back();
      std::cerr << "harness: sigma_IF " << std::setprecision(4) << noise << " seed " << s << ": " << std::fixed << std::setprecision(1)
                << r.total_wall_s << " s, Fig. 7 coverage " << 100 * r.fig7_coverage << " %, " << r.hyper_covered
                << "/7 covered\n" << std::defaultfloat;
    }
    const double n = static_cast<double>(runs.size());
    nlohmann::json entry;
    entry["noise_sd"] = noise;
    entry["failures"] = failures;
    if (runs.empty()) {
      md << "## sigma_IF = " << std::setprecision(4) << noise << "\n\nEvery run failed; the first: " << failures.front() << "\n\n";
      report["runs"].push_back(entry);
      continue;
    }
    if (!failures.empty()) {
      md << "## sigma_IF = " << std::setprecision(4) << noise << ": " << failures.size() << " of " << seeds << " runs failed (first: "
         << failures.front() << "); the statistics below are over the " << runs.size() << " that finished\n\n";
    }
    md << "## sigma_IF = " << std::setprecision(4) << noise << "\n\n| hyperparameter | truth | bias | RMSE | 95 % intervals covering the truth |\n"
       << "|---|---|---|---|---|\n";
    for (int j = 0; j < fleet::kHyperCount; ++j) {
      double bias = 0.0, mse = 0.0;
      int covered = 0;
      for (const auto& r : runs) {
        const double d = r.hyper[j].mean - r.truth[j];
        bias += d / n, mse += d * d / n;
        covered += r.truth[j] >= r.hyper[j].q025 && r.truth[j] <= r.hyper[j].q975;
      }
      const std::string name(fleet::kHyperNames[j]);
      entry["hyperparameters"][name] = {{"truth", runs[0].truth[j]}, {"bias", bias}, {"rmse", std::sqrt(mse)},
                                        {"covered", covered}, {"runs", runs.size()}};
      md << "| " << name << " | " << runs[0].truth[j] << " | " << std::setprecision(3) << bias << " | "
         << std::sqrt(mse) << " | " << covered << " of " << runs.size() << " |\n";
    }
    const auto stats = [&](auto get) {
      double lo = 1e300, hi = -1e300, mean = 0.0;
      for (const auto& r : runs) {
        const double v = get(r);
        lo = std::min(lo, v), hi = std::max(hi, v), mean += v / n;
      }
      return std::array<double, 3>{mean, lo, hi};
    };
    const auto c7 = stats([](const reproduce::Result& r) { return r.fig7_coverage; });
    const auto c8 = stats([](const reproduce::Result& r) { return r.fig8_coverage; });
    const auto d2 = stats([](const reproduce::Result& r) { return r.fig9.at(0).max_abs_mean_diff; });
    const auto d3 = stats([](const reproduce::Result& r) { return r.fig9.at(1).max_abs_mean_diff; });
    const auto p2 = stats([](const reproduce::Result& r) { return r.fig9.at(0).max_abs_population_diff; });
    const auto p3 = stats([](const reproduce::Result& r) { return r.fig9.at(1).max_abs_population_diff; });
    const auto o2 = stats([](const reproduce::Result& r) { return r.fig9.at(0).max_abs_oracle_diff; });
    const auto o3 = stats([](const reproduce::Result& r) { return r.fig9.at(1).max_abs_oracle_diff; });
    const auto h2 = stats([](const reproduce::Result& r) { return r.fig9.at(0).max_band_half_width; });
    const auto h3 = stats([](const reproduce::Result& r) { return r.fig9.at(1).max_band_half_width; });
    const auto wall = stats([](const reproduce::Result& r) { return r.total_wall_s; });
    int within2 = 0, within3 = 0, peak = 0, pop2 = 0, pop3 = 0, oracle2 = 0, oracle3 = 0;
    long band2 = 0, band3 = 0, sensors = 0;
    for (const auto& r : runs) {
      within2 += r.fig9.at(0).max_abs_mean_diff <= 0.01;
      within3 += r.fig9.at(1).max_abs_mean_diff <= 0.01;
      peak += r.fig8_predicted_peak == r.fig8_observed_peak;
      pop2 += r.fig9.at(0).max_abs_population_diff <= 0.01;
      pop3 += r.fig9.at(1).max_abs_population_diff <= 0.01;
      oracle2 += r.fig9.at(0).max_abs_oracle_diff <= 0.01;
      oracle3 += r.fig9.at(1).max_abs_oracle_diff <= 0.01;
      band2 += r.fig9.at(0).band_covers_population;
      band3 += r.fig9.at(1).band_covers_population;
      sensors += r.fig9.at(0).sensors;
    }
    const auto row = [&](const std::string& what, const std::array<double, 3>& v, double scale, int prec) {
      md << "| " << what << " | " << std::fixed << std::setprecision(prec) << scale * v[0] << " | " << scale * v[1]
         << " | " << scale * v[2] << " |\n" << std::defaultfloat;
    };
    md << "\n| over seeds | mean | min | max |\n|---|---|---|---|\n";
    row("Fig. 7 prediction coverage (%)", c7, 100, 1);
    row("Fig. 8 coverage at sensors 11-16 (%)", c8, 100, 1);
    row("Fig. 9 AS2 largest abs. mean difference", d2, 1, 4);
    row("Fig. 9 AS3 largest abs. mean difference", d3, 1, 4);
    row("Fig. 9 AS2 largest abs. difference from the population mean", p2, 1, 4);
    row("Fig. 9 AS3 largest abs. difference from the population mean", p3, 1, 4);
    row("Fig. 9 AS2 largest abs. difference, population mean vs new fleet (a perfect predictor)", o2, 1, 4);
    row("Fig. 9 AS3 largest abs. difference, population mean vs new fleet (a perfect predictor)", o3, 1, 4);
    row("Fig. 9 AS2 widest half-width of the 95 % band of the mean", h2, 1, 4);
    row("Fig. 9 AS3 widest half-width of the 95 % band of the mean", h3, 1, 4);
    row("wall time per reproduction (s)", wall, 1, 1);
    md << "\nAS2 mean within 0.01 IF at every sensor: " << within2 << " of " << runs.size()
       << "; AS3: " << within3 << " of " << runs.size() << "; Fig. 8 highest-mean sensor among 11-16 right: " << peak
       << " of " << runs.size() << ".\nAgainst the true fleet's population mean (20000 trucks): AS2 within 0.01 at every sensor "
       << pop2 << " of " << runs.size() << ", AS3 " << pop3 << " of " << runs.size()
       << ".\nA perfect predictor (the population mean) within 0.01 of the new fleet's mean at every sensor: AS2 " << oracle2
       << " of " << runs.size() << ", AS3 " << oracle3 << " of " << runs.size()
       << ".\nThe 95 % band of the predicted mean holds the population mean at " << band2 << " of " << sensors
       << " sensor-runs on AS2 and " << band3 << " of " << sensors << " on AS3.\n\n";
    entry["fig7_coverage"] = {{"mean", c7[0]}, {"min", c7[1]}, {"max", c7[2]}};
    entry["fig8_coverage"] = {{"mean", c8[0]}, {"min", c8[1]}, {"max", c8[2]}};
    entry["fig9_as2_max_abs_mean_diff"] = {{"mean", d2[0]}, {"min", d2[1]}, {"max", d2[2]}, {"within_0.01", within2}};
    entry["fig9_as3_max_abs_mean_diff"] = {{"mean", d3[0]}, {"min", d3[1]}, {"max", d3[2]}, {"within_0.01", within3}};
    entry["fig9_as2_max_abs_population_diff"] = {{"mean", p2[0]}, {"min", p2[1]}, {"max", p2[2]}, {"within_0.01", pop2}};
    entry["fig9_as3_max_abs_population_diff"] = {{"mean", p3[0]}, {"min", p3[1]}, {"max", p3[2]}, {"within_0.01", pop3}};
    entry["fig9_as2_max_abs_oracle_diff"] = {{"mean", o2[0]}, {"min", o2[1]}, {"max", o2[2]}, {"within_0.01", oracle2}};
    entry["fig9_as3_max_abs_oracle_diff"] = {{"mean", o3[0]}, {"min", o3[1]}, {"max", o3[2]}, {"within_0.01", oracle3}};
    entry["fig9_as2_band"] = {{"max_half_width", {{"mean", h2[0]}, {"min", h2[1]}, {"max", h2[2]}}},
                              {"holds_population_mean", band2}, {"sensor_runs", sensors}};
    entry["fig9_as3_band"] = {{"max_half_width", {{"mean", h3[0]}, {"min", h3[1]}, {"max", h3[2]}}},
                              {"holds_population_mean", band3}, {"sensor_runs", sensors}};
    entry["fig8_peak_right"] = peak;
    entry["wall_s"] = {{"mean", wall[0]}, {"min", wall[1]}, {"max", wall[2]}};
    report["runs"].push_back(entry);
  }
  if (!json_path.empty()) std::ofstream(json_path) << report.dump(1) << "\n";
  if (!md_path.empty()) std::ofstream(md_path) << md.str();
  std::cout << md.str();
  return 0;
}
