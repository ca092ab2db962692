// The diagnose benchmark: the wall time of `diagnose` on a 100-truck log, and how often it names the
// right effect as the fleet grows. Logs are Table 1 fleets on AS1 at sigma_IF = 0.02, simulated
// with the effect on and diagnosed with the whole catalogue; "none" logs have no effect, where
// the right answer is "none". Writes a JSON and a Markdown report.
//
//   diagnose_benchmark [--timing-effect sensor_gain:sensor=5,gain=1.05] [--timing-particles 512]
//                      [--timing-two sensor_gain:sensor=9,gain=1.06+unsprung_mass:m1=600] [--skip-prior]
//                      [--skip-detection]
//                      [--effects "sensor_gain:sensor=5,gain=1.05;tyre_damping:c_t=2000;none"]
//                      [--trucks 20,50,100,200] [--seeds 2] [--particles 256] [--threads 2]
//                      [--clean-logs 0] [--clean-trucks 100] [--runs FILE.jsonl] [--plot STEM] [--skip-timing]
//                      [--shard K/N] [--json FILE] [--markdown FILE]
// The detection part is the power table (diagnose_power.hpp): --seeds logs per
// (effect, fleet size), --clean-logs more clean logs of --clean-trucks for the pooled false-alarm
// rate, every run appended to --runs as it ends (a restart skips those), --plot STEM the figure.
// An effect's size is its setting's last parameter: write the one that grows last.
// --shard K/N takes only the runs whose place in the whole campaign's list is K modulo N (K from
// 0), so N processes (cores or machines) can share one --runs file: a diagnose's result does not
// depend on its thread count, each run appends one whole line, and the parts stay apart however the
// processes are started, stopped and restarted, since a place in the whole list never moves.
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "diagnose_power.hpp"
#include "run_info.hpp"
#include "discrepancy/diagnose.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_extension.hpp"
#include "model/model_spec.hpp"
#include "site/road_source.hpp"

using namespace ssrfleet;

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep)) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::vector<records::WimRecord> make_log(const site::Site& site, const std::string& setting, int trucks, std::uint64_t seed) {
  const auto fleet = fleet::draw_fleet(fleet::FleetDistribution{}, trucks, site.lateral_min_m(), site.lateral_max_m(), seed);
  if (setting == "none") return fleet::simulate_log(site, fleet, 0.02, seed).records;
  const auto e = fleet::parse_extension_setting(setting, site);
  return fleet::simulate_log(site, fleet, 0.02, seed, *e.extension, e.psi).records;
}


}  // namespace

int main(int argc, char** argv) {
  std::string timing_effect = "sensor_gain:sensor=5,gain=1.05", json_path, md_path;
  std::string timing_two = "sensor_gain:sensor=9,gain=1.06+unsprung_mass:m1=600";
  bool skip_prior = false;
  std::string effects_arg = "sensor_gain:sensor=5,gain=1.05;tyre_damping:c_t=2000;none";
  std::string trucks_arg = "20,50,100,200";
  int seeds = 2, particles = 256, timing_particles = 512, threads = 2, clean_logs = 0, clean_trucks = 100;
  std::string runs_path, plot_stem;
  bool skip_timing = false;
  int shard = 0, shards = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--timing-effect") timing_effect = next();
    else if (a == "--timing-two") timing_two = next();
    else if (a == "--skip-prior") skip_prior = true;
    else if (a == "--skip-detection") trucks_arg.clear();
    else if (a == "--skip-timing") skip_timing = true;
    else if (a == "--runs") runs_path = next();
    else if (a == "--clean-logs") clean_logs = std::stoi(next());
    else if (a == "--clean-trucks") clean_trucks = std::stoi(next());
    else if (a == "--plot") plot_stem = next();
    else if (a == "--timing-particles") timing_particles = std::stoi(next());
    else if (a == "--effects") effects_arg = next();
    else if (a == "--trucks") trucks_arg = next();
    else if (a == "--seeds") seeds = std::stoi(next());
    else if (a == "--particles") particles = std::stoi(next());
    else if (a == "--threads") threads = std::stoi(next());
    else if (a == "--shard") {
      const std::string v = next();
      const auto slash = v.find('/');
      try {
        if (slash == std::string::npos) throw std::invalid_argument(v);
        shard = std::stoi(v.substr(0, slash));
        shards = std::stoi(v.substr(slash + 1));
      } catch (const std::exception&) {
        shards = 0;
      }
      if (shards < 1 || shard < 0 || shard >= shards) {
        std::cerr << "diagnose_benchmark: --shard '" << v << "': want K/N with 0 <= K < N, as 0/2\n";
        return 64;
      }
    } else if (a == "--json") json_path = next();
    else if (a == "--markdown") md_path = next();
    else {
      std::cerr << "usage: diagnose_benchmark [--timing-effect SETTING] [--timing-two A+B] [--skip-prior] [--skip-detection] "
                   "[--timing-particles 512] [--effects \"A;B;none\"] "
                   "[--trucks 20,50,100,200] [--seeds 2] [--clean-logs 0] [--clean-trucks 100] [--runs FILE.jsonl] "
                   "[--plot STEM] [--skip-timing] [--particles 256] [--threads 2] [--shard K/N] [--json FILE] [--markdown FILE]\n";
      return a == "--help" || a == "-h" ? 0 : 64;
    }
  }
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  nlohmann::json report;
  std::ostringstream md;
  // The thread count belongs to the wall times of part 1 only: the detection table may pool runs
  // made at any thread count (the answers do not depend on it).
  md << "# diagnose benchmark (AS1, Table 1 fleet, sigma_IF = 0.02)\n\n";

  // 1. Wall time on 100 trucks with the default particle count (at most 60 s, and
  // a second effect at most as much again): one effect, then two at once, then (unless
  // --skip-prior) the one-effect log again with the candidates refitted the older way, each new
  // truck drawn from the fleet prior, side by side in this run.
  if (!skip_timing) {
    struct Timed {
      std::string label, setting;
      bool from_tables = true;
      double wall_s = 0.0;
    };
    std::vector<Timed> runs{{"one effect, refits from the base fit's tables", timing_effect, true},
                            {"two effects, refits from the base fit's tables", timing_two, true}};
    if (!skip_prior) runs.push_back({"one effect, refits drawing new trucks from the prior", timing_effect, false});
    md << "## Wall time on 100 trucks (" << timing_particles << " particles, the whole catalogue, " << threads
       << " threads)\n\n"
       << "| log | refits | wall time | base fit | each round | named | verdict | log Bayes factor of each effect named |\n"
       << "|---|---|---:|---:|---|---|---|---|\n";
    for (auto& run : runs) {
      discrepancy::DiagnoseOptions o;
      o.particles = timing_particles;
      o.threads = threads;
      o.seed = 1;
      o.refit_from_tables = run.from_tables;
      const auto fleet_trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 100, site.lateral_min_m(), site.lateral_max_m(), 1);
      const auto model = fleet::parse_simulation_model(run.setting, site);
      const auto log = fleet::simulate_log(site, fleet_trucks, 0.02, 1, *model.extension, model.psi).records;
      const auto t0 = std::chrono::steady_clock::now();
      const auto r = discrepancy::diagnose(site, log, o);
      run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::string factors, rounds;
      std::vector<double> round_s;
      for (const auto& step : r.steps) {
        std::ostringstream t;
        t << std::fixed << std::setprecision(1) << step.wall_s << " s";
        rounds += (rounds.empty() ? "" : ", ") + t.str();
        round_s.push_back(step.wall_s);
        if (step.effect.empty()) continue;
        std::ostringstream f;
        f << std::fixed << std::setprecision(1) << step.log_bayes_factor;
        factors += (factors.empty() ? "" : ", ") + step.effect + " " + f.str();
      }
      int refits = 0;
      for (const auto& step : r.steps)
        for (const auto& c : step.candidates) refits += c.refitted;
      report["timing"].push_back({{"log", run.setting}, {"refits_from", run.from_tables ? "tables" : "prior"},
                                  {"trucks", 100}, {"particles", timing_particles}, {"wall_s", run.wall_s},
                                  {"base_fit_s", r.base.wall_s}, {"refits", refits}, {"effects", r.effects},
                                  {"verdict", r.verdict}, {"round_s", round_s}});
      md << "| " << run.setting << " | " << (run.from_tables ? "tables" : "prior") << ", " << refits << " | **"
         << std::fixed << std::setprecision(1) << run.wall_s << " s** | " << r.base.wall_s << " s | " << rounds << " | "
         << (r.effects.empty() ? r.effect : r.model) << " | " << r.verdict << " | " << factors << " |\n"
         << std::defaultfloat;
      std::cerr << "timing: " << run.label << ": " << run.wall_s << " s, named " << r.model << "\n";
    }
    md << "\nTargets: one effect at most 60 s; a second effect at most as much again. A round is "
          "its refits, the chosen refit's final sweeps and its checks; the last round of a log finds nothing more "
          "to add (or, at --max-effects, is not run).";
    if (!skip_prior)
      md << " Speed-up of the table refits over the prior ones on the same log: **" << std::fixed << std::setprecision(1)
         << runs[2].wall_s / runs[0].wall_s << "x**." << std::defaultfloat;
    md << "\n\n";
  }

  // 2. Detection rate against effect size and fleet size, and false alarms on clean logs
  // (none with --skip-detection). Runs already in --runs are not done again.
  const auto effects = trucks_arg.empty() ? std::vector<std::string>{} : split(effects_arg, ';');
  std::vector<int> sizes;
  for (const auto& s : split(trucks_arg, ',')) sizes.push_back(std::stoi(s));
  std::vector<bench::power::Run> runs = runs_path.empty() ? std::vector<bench::power::Run>{} : bench::power::read_runs(runs_path);
  // Only runs at this particle count belong to this table.
  const auto other = std::erase_if(runs, [&](const bench::power::Run& r) { return r.particles != particles; });
  if (other > 0) std::cerr << "detection: " << other << " runs of " << runs_path << " at another particle count left out\n";
  const std::string commit = bench::run_command("git rev-parse --short HEAD 2>/dev/null");
  std::set<bench::power::Key> done;
  for (const auto& r : runs) done.insert(bench::power::key_of(r));
  std::vector<bench::power::Key> todo = bench::power::campaign(clean_logs, clean_trucks, sizes, effects, seeds);
  if (shards > 1) {
    const std::size_t whole = todo.size();
    todo = bench::power::shard_of(todo, shard, shards);
    std::cerr << "detection: shard " << shard << "/" << shards << " is " << todo.size() << " of the campaign's " << whole
              << " runs\n";
  }
  std::erase_if(todo, [&](const bench::power::Key& k) { return done.count(k) > 0; });
  if (!runs.empty()) std::cerr << "detection: " << runs.size() << " runs read from " << runs_path << ", " << todo.size() << " to do\n";
  double spent_s = 0.0;
  for (std::size_t k = 0; k < todo.size(); ++k) {
    const auto& [setting, trucks, seed] = todo[k];
    discrepancy::DiagnoseOptions o;
    o.particles = particles;
    o.threads = threads;
    o.seed = seed;
    // A diagnose that throws is a result of the campaign too, and a wrong one: it is recorded as
    // named "error" (its message in the verdict) and the campaign goes on. Delete its line from
    // the runs file to run it again once the cause is fixed.
    bench::power::Run run;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      const auto r = discrepancy::diagnose(site, make_log(site, setting, trucks, seed), o);
      run = {setting, trucks, seed, r.effect, r.verdict, r.wall_s, particles, commit};
    } catch (const std::exception& e) {
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      run = {setting, trucks, seed, "error", std::string("error: ") + e.what(), wall, particles, commit};
      std::cerr << "detection: " << setting << ", " << trucks << " trucks, seed " << seed << " threw: " << e.what()
                << "\n";
    }
    runs.push_back(run);
    if (!runs_path.empty()) bench::power::append_run(runs_path, run);
    spent_s += run.wall_s;
    const double left_s = spent_s / static_cast<double>(k + 1) * static_cast<double>(todo.size() - k - 1);
    std::cerr << "detection " << (k + 1) << "/" << todo.size() << ": " << setting << ", " << trucks << " trucks, seed "
              << seed << ": named " << run.named << " (" << std::fixed << std::setprecision(1) << run.wall_s
              << " s; about " << std::setprecision(0) << left_s / 60.0 << " min left)\n" << std::defaultfloat;
  }
  for (const auto& r : runs) {
    report["detection"].push_back({{"effect", r.setting}, {"trucks", r.trucks}, {"seed", r.seed}, {"named", r.named},
                                   {"verdict", r.verdict}, {"right", bench::power::right(r)}, {"wall_s", r.wall_s}});
  }
  if (!runs.empty()) {
    // Settings and sizes as asked, then any others the runs file holds (an earlier campaign's).
    std::vector<std::string> settings = effects;
    std::vector<int> all_sizes = sizes;
    for (const auto& r : runs) {
      if (r.setting != "none" && std::find(settings.begin(), settings.end(), r.setting) == settings.end())
        settings.push_back(r.setting);
      if (std::find(all_sizes.begin(), all_sizes.end(), r.trucks) == all_sizes.end()) all_sizes.push_back(r.trucks);
    }
    std::sort(all_sizes.begin(), all_sizes.end());
    if (std::find(settings.begin(), settings.end(), "none") == settings.end()) settings.push_back("none");
    md << bench::power::tables(runs, settings, all_sizes, std::to_string(particles) + " particles, the whole catalogue") << "\n";
    if (!plot_stem.empty()) {
      const std::string problem = bench::power::write_plot(plot_stem, runs, all_sizes);
      md << "Plot: `" << plot_stem << ".png` (data `" << plot_stem << ".csv`)";
      if (!problem.empty()) md << "; " << problem;
      md << ".\n\n";
    }
  }
  if (!json_path.empty()) std::ofstream(json_path) << report.dump(1) << "\n";
  if (!md_path.empty()) std::ofstream(md_path) << md.str();
  std::cout << md.str();
  return 0;
}
