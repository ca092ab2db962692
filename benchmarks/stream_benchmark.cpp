// Stream benchmark: sustained trucks per second (exact and windowed, default particles) and the
// resident memory of a windowed stream after 1 000, 10 000 and 100 000 trucks. Memory is the
// process's resident set (VmRSS) read from /proc/self/status; the synthetic stream cycles
// through a simulated fleet under fresh truck ids (the posterior does not care that trucks
// repeat; the memory would grow just the same if they did not).
//
//   stream_benchmark [--rate-trucks 60] [--particles 1024] [--memory-trucks 100000]
//                    [--memory-particles 16] [--window 20] [--json FILE]
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleet/fleet_smc.hpp"
#include "fleet/simulator.hpp"
#include "run_info.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"

using namespace ssrfleet;

namespace {

double trucks_per_second(const site::Site& site, const std::vector<records::WimRecord>& records, long particles,
                         Eigen::Index window) {
  fleet::FleetSmc::Options o;
  o.sampler.particles = particles;
  o.sampler.seed = 1;
  o.window = window;
  fleet::FleetSmc smc(site, o);
  const auto start = std::chrono::steady_clock::now();
  for (const auto& r : records) smc.absorb(r);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return static_cast<double>(records.size()) / s;
}
}  // namespace

int main(int argc, char** argv) {
  long rate_trucks = 60, particles = 1024, memory_trucks = 100000, memory_particles = 16;
  Eigen::Index window = 20;
  std::string json_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--rate-trucks") rate_trucks = std::stol(next());
    else if (a == "--particles") particles = std::stol(next());
    else if (a == "--memory-trucks") memory_trucks = std::stol(next());
    else if (a == "--memory-particles") memory_particles = std::stol(next());
    else if (a == "--window") window = std::stol(next());
    else if (a == "--json") json_path = next();
    else {
      std::cerr << "usage: stream_benchmark [--rate-trucks N] [--particles P] [--memory-trucks N] "
                   "[--memory-particles P] [--window W] [--json FILE]\n";
      return a == "--help" ? 0 : 64;
    }
  }
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, 200, site.lateral_min_m(), site.lateral_max_m(), 1);
  const auto log = fleet::simulate_log(site, trucks, 0.02, 1);
  std::vector<records::WimRecord> rate_records(log.records.begin(), log.records.begin() + std::min<long>(rate_trucks, 200));

  nlohmann::json out;
  out["threads"] = std::thread::hardware_concurrency();
  const double exact = trucks_per_second(site, rate_records, particles, 0);
  const double windowed = trucks_per_second(site, rate_records, particles, window);
  std::cout << "sustained rate over " << rate_records.size() << " trucks, " << particles << " particles, "
            << std::thread::hardware_concurrency() << " threads:\n"
            << "  exact    " << std::fixed << std::setprecision(2) << exact << " trucks/s\n"
            << "  window " << window << "  " << windowed << " trucks/s   (target >= 1 truck/s)\n";
  out["rate"] = {{"trucks", rate_records.size()}, {"particles", particles}, {"exact_trucks_per_s", exact},
                 {"window", window}, {"windowed_trucks_per_s", windowed}};

  fleet::FleetSmc::Options o;
  o.sampler.particles = memory_particles;
  o.sampler.seed = 2;
  o.window = window;
  fleet::FleetSmc smc(site, o);
  nlohmann::json memory = nlohmann::json::array();
  const auto start = std::chrono::steady_clock::now();
  long at_1000 = 0;
  for (long t = 1; t <= memory_trucks; ++t) {
    records::WimRecord r = log.records[static_cast<std::size_t>((t - 1) % 200)];
    r.truck_id = std::to_string(t);  // fresh ids (a prefix would trip GCC 12's -Wrestrict false positive)
    smc.absorb(r);
    if (t == 1000 || t == 10000 || t == 100000 || t == memory_trucks) {
      const long kb = bench::resident_kb();
      if (t == 1000) at_1000 = kb;
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::cout << "windowed memory after " << t << " trucks (" << memory_particles << " particles, window " << window
                << "): " << kb << " kB resident" << (at_1000 > 0 ? ", " : "")
                << (at_1000 > 0 ? std::to_string(100.0 * (kb - at_1000) / at_1000) + " % vs 1000 trucks" : "")
                << " [" << std::setprecision(0) << s << " s]" << std::setprecision(2) << std::endl;
      memory.push_back({{"trucks", t}, {"resident_kb", kb}, {"seconds", s}});
    }
  }
  out["memory"] = {{"particles", memory_particles}, {"window", window}, {"points", memory}};
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << "\n";
  return 0;
}
