// How often does `sites --check` (discrepancy/site_conflicts.hpp) name a site of a network whose
// sites all share one fleet? Runs the check on R simulated networks of S sites of the Table 1 fleet
// (the preset roads and sensor arrays in turn, each network its own seeds) and reports the share of
// networks with a site flagged (the family-wise false-alarm rate, nominally at most alpha) with its
// 95 % Clopper-Pearson interval, and the first round's p-values (uniform if the χ²_4 reference holds).
//   site_check_calibration_benchmark [--networks 20] [--sites 3] [--trucks 40] [--particles 256]
//                                    [--threads 2] [--seed 1] [--alpha 0.01]
#include <algorithm>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>
#include <vector>


#include "discrepancy/site_conflicts.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"
#include "util/binomial_interval.hpp"

using namespace ssrfleet;

namespace {
struct Args {
  int networks = 20, sites = 3, trucks = 40, threads = 2;
  long particles = 256;
  std::uint64_t seed = 1;
  double alpha = 0.01;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--networks") a.networks = std::stoi(v);
    else if (k == "--sites") a.sites = std::stoi(v);
    else if (k == "--trucks") a.trucks = std::stoi(v);
    else if (k == "--particles") a.particles = std::stol(v);
    else if (k == "--threads") a.threads = std::stoi(v);
    else if (k == "--seed") a.seed = std::stoull(v);
    else if (k == "--alpha") a.alpha = std::stod(v);
    else {
      std::cerr << "unknown option " << k << "\n";
      std::exit(64);
    }
  }
  if (a.networks < 1 || a.sites < 2 || a.trucks < 2) {
    std::cerr << "need --networks >= 1, --sites >= 2, --trucks >= 2\n";
    std::exit(64);
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  struct Spec {
    const char* road;
    double first, spacing;
    int count;
  };
  const Spec specs[] = {{"AS1", 76, 1.5, 16}, {"AS2", 70, 2, 8}, {"AS3", 60, 1.5, 12}, {"AS1", 40, 2, 10}, {"AS2", 20, 1.5, 16}};
  std::vector<std::unique_ptr<site::Site>> sites;
  std::vector<const site::Site*> pointers;
  for (int s = 0; s < a.sites; ++s) {
    const Spec& spec = specs[s % 5];
    site::SiteOptions o;
    o.sensors = {spec.first, spec.spacing, spec.count};
    sites.push_back(std::make_unique<site::Site>(site::load_road(spec.road), o));
    pointers.push_back(sites.back().get());
  }
  discrepancy::SiteConflictOptions o;
  o.fit.marginal.sampler.particles = a.particles;
  o.fit.marginal.sampler.threads = a.threads;
  o.alpha = a.alpha;
  int flagged_networks = 0, undecided_networks = 0;
  std::vector<double> p_first;
  for (int r = 0; r < a.networks; ++r) {
    std::vector<std::vector<records::WimRecord>> logs;
    for (int s = 0; s < a.sites; ++s) {
      const std::uint64_t seed = a.seed * 1000003ULL + static_cast<std::uint64_t>(r) * 101ULL + static_cast<std::uint64_t>(s);
      const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, a.trucks, sites[s]->lateral_min_m(),
                                            sites[s]->lateral_max_m(), seed);
      logs.push_back(fleet::simulate_log(*sites[s], trucks, 0.02, seed + 7).records);
    }
    o.fit.marginal.sampler.seed = a.seed * 7919ULL + static_cast<std::uint64_t>(r);
    const auto result = discrepancy::check_site_conflicts(pointers, logs, o);
    bool any = false, undecided = false;
    double min_p = 1.0;
    for (const auto& c : result) {
      any = any || c.flagged;
      undecided = undecided || c.undecided;
      if (c.round == 1) p_first.push_back(c.p_value);
      min_p = std::min(min_p, c.p_value);
    }
    flagged_networks += any ? 1 : 0;
    undecided_networks += undecided ? 1 : 0;
    std::cout << "network " << (r + 1) << "/" << a.networks << ": min p " << std::setprecision(3) << min_p
              << (any ? ", a site flagged" : "") << (undecided ? ", undecided" : "") << std::endl;
  }
  const auto [lo, hi] = util::clopper_pearson(flagged_networks, a.networks);
  int below[3] = {0, 0, 0};
  for (double p : p_first) {
    below[0] += p < 0.5 ? 1 : 0;
    below[1] += p < 0.1 ? 1 : 0;
    below[2] += p < 0.05 ? 1 : 0;
  }
  const double n = static_cast<double>(p_first.size());
  std::cout << std::setprecision(4) << "networks " << a.networks << " of " << a.sites << " sites x " << a.trucks
            << " trucks (one fleet), particles " << a.particles << ", alpha " << a.alpha << "\n"
            << "networks with a site flagged: " << flagged_networks << " (" << flagged_networks / double(a.networks)
            << ", 95 % Clopper-Pearson [" << lo << ", " << hi << "]); undecided: " << undecided_networks << "\n"
            << "first-round p-values (" << p_first.size() << "): below 0.5 " << below[0] / n << ", below 0.1 "
            << below[1] / n << ", below 0.05 " << below[2] / n << " (uniform: 0.5, 0.1, 0.05)\n";
  return 0;
}
