// Issue 6's benchmark: the wall time of `diagnose` on a 100-truck log, and how often it names the
// right effect as the fleet grows. Logs are Table 1 fleets on AS1 at sigma_IF = 0.02, simulated
// with the effect on and diagnosed with the whole catalogue; "none" logs have no effect, where
// the right answer is "none". Writes a JSON and a Markdown report.
//
//   diagnose_benchmark [--timing-effect sensor_gain:sensor=5,gain=1.05] [--timing-particles 512]
//                      [--effects "sensor_gain:sensor=5,gain=1.05;tyre_damping:c_t=2000;none"]
//                      [--trucks 20,50,100,200] [--seeds 2] [--particles 256] [--threads 2]
//                      [--json FILE] [--markdown FILE]
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "discrepancy/diagnose.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_extension.hpp"
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

std::string effect_name(const std::string& setting) { return setting.substr(0, setting.find(':')); }

}  // namespace

int main(int argc, char** argv) {
  std::string timing_effect = "sensor_gain:sensor=5,gain=1.05", json_path, md_path;
  std::string effects_arg = "sensor_gain:sensor=5,gain=1.05;tyre_damping:c_t=2000;none";
  std::string trucks_arg = "20,50,100,200";
  int seeds = 2, particles = 256, timing_particles = 512, threads = 2;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--timing-effect") timing_effect = next();
    else if (a == "--timing-particles") timing_particles = std::stoi(next());
    else if (a == "--effects") effects_arg = next();
    else if (a == "--trucks") trucks_arg = next();
    else if (a == "--seeds") seeds = std::stoi(next());
    else if (a == "--particles") particles = std::stoi(next());
    else if (a == "--threads") threads = std::stoi(next());
    else if (a == "--json") json_path = next();
    else if (a == "--markdown") md_path = next();
    else {
      std::cerr << "usage: diagnose_benchmark [--timing-effect SETTING] [--timing-particles 512] [--effects \"A;B;none\"] "
                   "[--trucks 20,50,100,200] [--seeds 2] [--particles 256] [--threads 2] [--json FILE] [--markdown FILE]\n";
      return a == "--help" || a == "-h" ? 0 : 64;
    }
  }
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  nlohmann::json report;
  std::ostringstream md;
  md << "# diagnose benchmark (AS1, Table 1 fleet, sigma_IF = 0.02, " << threads << " threads)\n\n";

  // 1. Wall time on 100 trucks with the default particle count.
  {
    discrepancy::DiagnoseOptions o;
    o.particles = timing_particles;
    o.threads = threads;
    o.seed = 1;
    const auto log = make_log(site, timing_effect, 100, 1);
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = discrepancy::diagnose(site, log, o);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    int refits = 0;
    for (const auto& c : r.candidates) refits += c.refitted;
    report["timing"] = {{"effect", timing_effect}, {"trucks", 100}, {"particles", timing_particles}, {"wall_s", wall},
                        {"base_fit_s", r.base.wall_s}, {"refits", refits}, {"named", r.effect}};
    md << "## Wall time on 100 trucks\n\n" << timing_effect << ", " << timing_particles << " particles: **"
       << std::fixed << std::setprecision(1) << wall << " s** (target 300 s); base fit " << r.base.wall_s << " s, "
       << refits << " refits; named: " << r.effect << "\n\n" << std::defaultfloat;
    std::cerr << "timing: " << wall << " s, named " << r.effect << "\n";
  }

  // 2. Detection rate against the number of trucks.
  const auto effects = split(effects_arg, ';');
  std::vector<int> sizes;
  for (const auto& s : split(trucks_arg, ',')) sizes.push_back(std::stoi(s));
  md << "## Detection rate (" << seeds << " seeds per cell, " << particles << " particles)\n\n"
     << "A cell is right/runs: the named effect is the simulated one (for `none`: nothing named). Below it, what was named "
        "instead and the mean wall time.\n\n| effect |";
  for (int n : sizes) md << " " << n << " trucks |";
  md << "\n|---|";
  for (std::size_t k = 0; k < sizes.size(); ++k) md << "---|";
  md << "\n";
  for (const auto& setting : effects) {
    const std::string want = effect_name(setting);
    md << "| " << setting << " |";
    for (int n : sizes) {
      int right = 0;
      double wall = 0.0;
      std::map<std::string, int> named;
      for (int s = 1; s <= seeds; ++s) {
        discrepancy::DiagnoseOptions o;
        o.particles = particles;
        o.threads = threads;
        o.seed = static_cast<std::uint64_t>(100 + s);
        const auto r = discrepancy::diagnose(site, make_log(site, setting, n, o.seed), o);
        right += r.effect == want;
        ++named[r.effect];
        wall += r.wall_s;
        report["detection"].push_back({{"effect", setting}, {"trucks", n}, {"seed", o.seed}, {"named", r.effect},
                                       {"log_bayes_factor", r.log_bayes_factor}, {"wall_s", r.wall_s}});
        std::cerr << "detection: " << setting << ", " << n << " trucks, seed " << o.seed << ": named " << r.effect
                  << " (" << std::fixed << std::setprecision(1) << r.wall_s << " s)\n" << std::defaultfloat;
      }
      md << " " << right << "/" << seeds << " (";
      bool first = true;
      for (const auto& [name, count] : named) {
        md << (first ? "" : ", ") << name << " " << count;
        first = false;
      }
      md << "; " << std::fixed << std::setprecision(0) << wall / seeds << " s) |" << std::defaultfloat;
    }
    md << "\n";
  }
  if (!json_path.empty()) std::ofstream(json_path) << report.dump(1) << "\n";
  if (!md_path.empty()) std::ofstream(md_path) << md.str();
  std::cout << md.str();
  return 0;
}
