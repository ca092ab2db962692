// The power and false-alarm table of `diagnose`: detection rate against effect
// size and fleet size, the false-alarm rate pooled over clean logs, each with its Clopper-Pearson
// 95 % interval, and a plot of detection probability against effect size, one panel per effect.
//
// A campaign runs for hours, so every diagnose is appended to a runs file (JSON lines) as it ends,
// and a restart with the same file skips the runs already there: a campaign survives a reboot or
// a kill and can be spread over nights. The tables are made from the runs file alone.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/gnuplot_runner.hpp"
#include "report_format.hpp"
#include "util/binomial_interval.hpp"

namespace ssrfleet::bench::power {

// One diagnose of one simulated log. `setting` is the effect simulated ("none": a clean log).
struct Run {
  std::string setting;
  int trucks = 0;
  std::uint64_t seed = 0;
  std::string named;    // the result's `effect`: the first effect named, "none" or "unexplained"
  std::string verdict;  // "none", "explained" or "unexplained"
  double wall_s = 0.0;
  int particles = 0;
  std::string commit;  // of the code that ran it: a campaign spread over sessions may mix commits
};

inline std::string effect_of(const std::string& setting) { return setting.substr(0, setting.find(':')); }

// The size of a setting's effect: its last parameter ("sensor_gain:sensor=5,gain=1.05": gain,
// 1.05). Settings list the parameter that grows last; {"", 0} for "none" or a setting without one.
inline std::pair<std::string, double> size_of(const std::string& setting) {
  const auto colon = setting.find(':');
  if (colon == std::string::npos) return {"", 0.0};
  const std::string last = setting.substr(setting.find_last_of(",:") + 1);
  const auto eq = last.find('=');
  if (eq == std::string::npos) return {"", 0.0};
  return {last.substr(0, eq), std::stod(last.substr(eq + 1))};
}

// Right: the log's own effect named first; on a clean log, nothing named and no gap ("none").
inline bool right(const Run& r) { return r.named == (r.setting == "none" ? std::string("none") : effect_of(r.setting)); }

using Key = std::tuple<std::string, int, std::uint64_t>;
inline Key key_of(const Run& r) { return {r.setting, r.trucks, r.seed}; }

// Every run of a campaign, in the order it is run: the order makes a campaign stopped part-way
// worth most: the clean logs first (seeds 2001…; the false-alarm rate is a yes-or-no target), then
// every setting at the smallest fleet size before the next size (seeds 101…; a 400-truck diagnose
// costs about six 100-truck ones).
inline std::vector<Key> campaign(int clean_logs, int clean_trucks, std::vector<int> sizes,
                                 const std::vector<std::string>& settings, int seeds) {
  std::vector<Key> runs;
  for (int s = 1; s <= clean_logs; ++s) runs.emplace_back("none", clean_trucks, static_cast<std::uint64_t>(2000 + s));
  std::sort(sizes.begin(), sizes.end());
  for (int n : sizes)
    for (const auto& setting : settings)
      for (int s = 1; s <= seeds; ++s) runs.emplace_back(setting, n, static_cast<std::uint64_t>(100 + s));
  return runs;
}

// Part `shard` of `shards` (0 <= shard < shards) of a campaign: the runs whose place in the whole
// list is `shard` modulo `shards`. Taken before the done runs are dropped, so a run's part never
// moves however the processes are started, stopped and restarted, and the parts never overlap.
inline std::vector<Key> shard_of(const std::vector<Key>& whole, int shard, int shards) {
  std::vector<Key> part;
  for (auto k = static_cast<std::size_t>(shard); k < whole.size(); k += static_cast<std::size_t>(shards))
    part.push_back(whole[k]);
  return part;
}

// Reads the runs file; a line that does not parse (a run killed mid-write) is skipped with a
// warning, so the run it held is simply done again. A run repeated (the same setting, trucks, seed
// and particle count, as two processes given the same part would write) counts once, the first.
inline std::vector<Run> read_runs(const std::string& path) {
  std::vector<Run> runs;
  std::map<std::pair<Key, int>, int> first_line;  // (run, particles) -> the line it was first on
  std::ifstream in(path);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    Run r;
    try {
      const auto j = nlohmann::json::parse(line);
      r = {j.at("setting"), j.at("trucks"), j.at("seed"), j.at("named"), j.at("verdict"), j.at("wall_s"),
           j.at("particles"), j.at("commit")};
    } catch (const std::exception& e) {
      std::cerr << "warning: " << path << " line " << number << " skipped (" << e.what() << ")\n";
      continue;
    }
    const auto [at, is_new] = first_line.try_emplace({key_of(r), r.particles}, number);
    if (!is_new) {
      std::cerr << "warning: " << path << " line " << number << " repeats the run of line " << at->second
                << "; counted once\n";
      continue;
    }
    runs.push_back(std::move(r));
  }
  return runs;
}

inline void append_run(const std::string& path, const Run& r) {
  std::ofstream out(path, std::ios::app);
  out << nlohmann::json{{"setting", r.setting}, {"trucks", r.trucks}, {"seed", r.seed}, {"named", r.named},
                        {"verdict", r.verdict}, {"wall_s", r.wall_s}, {"particles", r.particles}, {"commit", r.commit}}
                .dump()
      << "\n";
  out.flush();
  if (!out) std::cerr << "warning: cannot append to " << path << "\n";
}

struct Cell {
  int right = 0, runs = 0;
  double wall_s = 0.0;
  std::map<std::string, int> named;
};

// The runs tallied per (setting, fleet size).
inline std::map<std::pair<std::string, int>, Cell> cells_of(const std::vector<Run>& runs) {
  std::map<std::pair<std::string, int>, Cell> cells;
  for (const auto& r : runs) {
    Cell& c = cells[{r.setting, r.trucks}];
    c.right += right(r);
    ++c.runs;
    c.wall_s += r.wall_s;
    ++c.named[r.named];
  }
  return cells;
}

inline std::string percent(double p) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1) << 100.0 * p;
  return s.str();
}

inline std::string interval(int x, int n) {
  const auto ci = util::clopper_pearson(x, n);
  std::string s("[");
  s.append(percent(ci.lower)).append(", ").append(percent(ci.upper)).append("] %");
  return s;
}

// The Markdown tables: detection per (setting, fleet size), then the false alarms pooled over
// every clean log. `settings` and `sizes` fix the order; cells without runs are left out.
inline std::string tables(const std::vector<Run>& runs, const std::vector<std::string>& settings,
                          const std::vector<int>& sizes, const std::string& how) {
  const auto cells = cells_of(runs);
  std::set<std::string> commits;
  for (const auto& r : runs) commits.insert(r.commit);
  std::string commit_list;
  for (const auto& c : commits) commit_list += (commit_list.empty() ? "" : ", ") + c;
  std::ostringstream md;
  md << "## Detection rate against effect size and fleet size (" << how << "; " << runs.size() << " runs at commit "
     << commit_list << ")\n\n"
        "A cell: right/runs, the rate's Clopper-Pearson 95 % interval, what was named (first effect, or the "
        "verdict when none was) and the mean wall time. Right: the simulated effect named first; on a clean log "
        "(`none`), nothing named and no check failing.\n\n| effect |";
  for (int n : sizes) md << " " << n << " trucks |";
  md << "\n|---|";
  for (std::size_t k = 0; k < sizes.size(); ++k) md << "---|";
  md << "\n";
  for (const auto& setting : settings) {
    md << "| " << setting << " |";
    for (int n : sizes) {
      const auto it = cells.find({setting, n});
      if (it == cells.end()) {
        md << " - |";
        continue;
      }
      const Cell& c = it->second;
      md << " " << c.right << "/" << c.runs << " " << interval(c.right, c.runs) << " (";
      bool first = true;
      for (const auto& [name, count] : c.named) {
        md << (first ? "" : ", ") << name << " " << count;
        first = false;
      }
      md << "; " << std::fixed << std::setprecision(0) << c.wall_s / c.runs << " s) |" << std::defaultfloat;
    }
    md << "\n";
  }
  int clean = 0, alarms = 0;
  for (const auto& r : runs) {
    if (r.setting != "none") continue;
    ++clean;
    alarms += !right(r);
  }
  if (clean > 0) {
    const auto ci = util::clopper_pearson(alarms, clean);
    md << "\n**False alarms** (anything but `none` on a clean log), pooled over every clean log of every fleet "
          "size: **"
       << alarms << " of " << clean << "** (" << percent(static_cast<double>(alarms) / clean)
       << " %), Clopper-Pearson 95 % interval " << interval(alarms, clean)
       << ". Target: at most 5 % over at least 100 clean logs: "
       << (clean < 100 ? "too few clean logs to judge"
                       : (ci.upper <= 0.05 ? "met (the interval's upper end is within 5 %)"
                                           : (static_cast<double>(alarms) / clean <= 0.05
                                                  ? "rate within 5 %, but the interval reaches above it"
                                                  : "missed")))
       << ".\n";
  }
  return md.str();
}

// gnuplot's "set xtics (...)" with a tic at each value, whole numbers written out whole: gnuplot's
// automatic tics for K2 (700000 and 1000000 N/m) ran into each other.
inline std::string xtics_at(const std::set<double>& values) {
  std::ostringstream tics;
  tics << "set xtics (";
  bool first = true;
  for (const double v : values) {
    std::ostringstream label;
    if (v == std::round(v) && std::abs(v) < 1e12) label << std::fixed << std::setprecision(0);
    label << v;
    tics << (first ? "" : ", ") << "'" << label.str() << "' " << std::setprecision(17) << v;
    first = false;
  }
  tics << ")\n";
  return tics.str();
}

// STEM.csv (effect, size parameter and value, trucks, right, runs, rate and its interval),
// STEM-false-alarms.csv (per fleet size of clean logs: alarms, logs, rate and its interval), STEM.gp
// and, where gnuplot is installed, STEM.png and STEM.svg: one panel per effect, detection rate
// against the size parameter, one line per fleet size, the intervals as error bars; then one panel
// of the clean logs' false-alarm rate against the 5 % target. Returns "" or what went wrong.
inline std::string write_plot(const std::string& stem_path, const std::vector<Run>& runs, const std::vector<int>& sizes) {
  struct Point {
    std::string parameter;
    double size = 0.0;
    int trucks = 0, right = 0, runs = 0;
  };
  std::map<std::string, std::vector<Point>> by_effect;  // in effect-name order
  for (const auto& [k, c] : cells_of(runs)) {
    const auto [parameter, size] = size_of(k.first);
    if (parameter.empty()) continue;
    by_effect[effect_of(k.first)].push_back({parameter, size, k.second, c.right, c.runs});
  }
  // Clean logs per fleet size, for the false-alarm panel.
  std::map<int, std::pair<int, int>> alarms_by_size;  // trucks -> (alarms, logs)
  for (const auto& r : runs) {
    if (r.setting != "none") continue;
    auto& [alarms, logs] = alarms_by_size[r.trucks];
    alarms += !right(r);
    ++logs;
  }
  if (by_effect.empty()) return "no effect with a size to plot";
  const std::filesystem::path stem(stem_path);
  const std::string dir = stem.parent_path().empty() ? "." : stem.parent_path().string();
  const std::string name = stem.filename().string(), csv = name + ".csv";
  {
    std::ofstream f = open_results_file((std::filesystem::path(dir) / csv).string());
    f << "effect,parameter,size,trucks,right,runs,rate,lower95,upper95\n";
    for (auto& [effect, points] : by_effect) {
      std::sort(points.begin(), points.end(), [](const Point& a, const Point& b) {
        return std::tie(a.trucks, a.size) < std::tie(b.trucks, b.size);
      });
      for (const auto& p : points) {
        const auto ci = util::clopper_pearson(p.right, p.runs);
        f << effect << "," << p.parameter << "," << p.size << "," << p.trucks << "," << p.right << "," << p.runs << ","
          << static_cast<double>(p.right) / p.runs << "," << ci.lower << "," << ci.upper << "\n";
      }
    }
  }
  const std::string alarms_csv = name + "-false-alarms.csv";
  if (!alarms_by_size.empty()) {
    std::ofstream f = open_results_file((std::filesystem::path(dir) / alarms_csv).string());
    f << "trucks,alarms,logs,rate,lower95,upper95\n";
    for (const auto& [trucks, count] : alarms_by_size) {
      const auto ci = util::clopper_pearson(count.first, count.second);
      f << trucks << "," << count.first << "," << count.second << ","
        << static_cast<double>(count.first) / count.second << "," << ci.lower << "," << ci.upper << "\n";
    }
  }
  const auto panels = static_cast<int>(by_effect.size() + (alarms_by_size.empty() ? 0 : 1));
  const int columns = std::min(panels, 3), rows = (panels + columns - 1) / columns;
  std::ostringstream body;
  body << "set datafile separator ','\nset multiplot layout " << rows << "," << columns
       << " title 'diagnose: detection probability against effect size (Clopper-Pearson 95 % bars)'\n"
       << "set yrange [-0.05:1.05]\nset ylabel 'detection probability'\nset key bottom right\nset grid\n"
       << "set offsets graph 0.08, graph 0.08, 0, 0\n";
  for (const auto& [effect, points] : by_effect) {
    std::set<double> run_sizes;
    for (const auto& p : points) run_sizes.insert(p.size);
    body << xtics_at(run_sizes);
    body << "set title '" << effect << "' noenhanced\nset xlabel '" << points.front().parameter << "' noenhanced\nplot ";
    bool first = true;
    for (int n : sizes) {
      body << (first ? "" : ", ") << "'" << csv << "' skip 1 using (strcol(1) eq '" << effect << "' && $4 == " << n
           << " ? $3 : NaN):7:8:9 with yerrorlines title '" << n << " trucks'";
      first = false;
    }
    body << "\n";
  }
  if (!alarms_by_size.empty()) {
    // The clean logs' panel: the rate of anything named against the 5 % target, on an axis that
    // shows a few per cent (a 0-1 axis would flatten it onto the floor).
    body << "set title 'clean logs: false alarms' noenhanced\nset xlabel 'trucks'\nset ylabel 'false-alarm rate'\n"
         << "set yrange [0:0.25]\nset key top right\n";
    std::set<double> fleet_sizes;
    for (const auto& [trucks, count] : alarms_by_size) fleet_sizes.insert(trucks);
    body << xtics_at(fleet_sizes) << "set arrow from graph 0, first 0.05 to graph 1, first 0.05 nohead dashtype 2\n"
         << "plot '" << alarms_csv << "' skip 1 using 1:4:5:6 with yerrorbars pt 7 title 'pooled per size, 95 % bars', "
         << "NaN with lines dashtype 2 lc 'black' title 'target 5 %'\nunset arrow\n";
  }
  body << "unset multiplot\n";
  std::ofstream(std::filesystem::path(dir) / (name + ".gp"))
      << io::png_and_svg_script(name, body.str(), 420 * columns + 80, 360 * rows + 60);
  if (!io::gnuplot_available()) return "gnuplot not found: run `gnuplot " + name + ".gp` in " + dir;
  const std::vector<std::string> failed = io::run_gnuplot(dir, {io::PlotScript{name, ""}});
  return failed.empty() ? "" : "gnuplot failed: see " + dir + "/" + name + ".gnuplot.log";
}

}  // namespace ssrfleet::bench::power
