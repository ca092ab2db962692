// Are the fitted sensor gains (discrepancy/sensor_calibration.hpp) right within their standard
// errors? Simulates R networks of two sites of the Table 1 fleet (AS1 with 16 sensors, sensor 5
// reading 6 % high; AS2 with 8 sensors at 2 m, every one reading 4 % low), each its own seeds, runs
// the Monte Carlo EM and reports z = (ĝ - g) / se over every gain: mean z² (1 if the standard errors
// are right), the largest |z|, the rounds the EM took, and the time.
// With --check, exit 1 unless mean z² lies in the central 99.8 % of its reference: 24 R gains,
// Σ z² ~ χ²(24 R) if they were independent (they are nearly: a site's gains share its trucks), so
// mean z² in 1 ± 3.09 sqrt(2 / (24 R)) (normal approximation; 0.80-1.20 at R = 20).
//   sensor_calibration_benchmark [--networks 20] [--trucks 80] [--particles 256] [--threads 2] [--seed 1] [--check]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "discrepancy/sensor_calibration.hpp"
#include "fleet/joint_sites.hpp"
#include "fleet/replay.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"

using namespace ssrfleet;

namespace {
struct Args {
  int networks = 20, trucks = 80, threads = 2;
  long particles = 256;
  std::uint64_t seed = 1;
  bool check = false;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--check") {
      a.check = true;
      continue;
    }
    if (i + 1 >= argc) {
      std::cerr << "option " << k << " needs a value\n";
      std::exit(64);
    }
    const std::string v = argv[++i];
    if (k == "--networks") a.networks = std::stoi(v);
    else if (k == "--trucks") a.trucks = std::stoi(v);
    else if (k == "--particles") a.particles = std::stol(v);
    else if (k == "--threads") a.threads = std::stoi(v);
    else if (k == "--seed") a.seed = std::stoull(v);
    else {
      std::cerr << "unknown option " << k << "\n";
      std::exit(64);
    }
  }
  if (a.networks < 1 || a.trucks < 10 || a.particles < 16 || a.threads < 1) {
    std::cerr << "need --networks >= 1, --trucks >= 10, --particles >= 16, --threads >= 1\n";
    std::exit(64);
  }
  return a;
}

site::Site make_site(const char* road, double first_m, double spacing_m, int count) {
  site::SiteOptions o;
  o.sensors = {first_m, spacing_m, count};
  return site::Site(site::load_road(road), o);
}
}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  const site::Site north = make_site("AS1", 76.0, 1.5, 16), south = make_site("AS2", 70.0, 2.0, 8);
  const std::vector<const site::Site*> sites{&north, &south};
  std::vector<Eigen::VectorXd> truth{Eigen::VectorXd::Ones(16), Eigen::VectorXd::Constant(8, 0.96)};
  truth[0][4] = 1.06;
  double z2 = 0.0, largest = 0.0;
  long gains = 0, rounds = 0, unconverged = 0;
  const auto start = std::chrono::steady_clock::now();
  std::cout << "network  rounds  mean z^2  max |z|  sensor-5 gain (1.06)  south mean gain (0.96)  s\n";
  for (int r = 0; r < a.networks; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::uint64_t base = a.seed * 1000 + static_cast<std::uint64_t>(r) * 10;
    std::vector<std::vector<records::WimRecord>> per_site;
    for (std::size_t s = 0; s < sites.size(); ++s) {
      const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, a.trucks, sites[s]->lateral_min_m(),
                                            sites[s]->lateral_max_m(), base + s);
      auto log = fleet::simulate_log(*sites[s], trucks, 0.02, base + 5 + s).records;
      for (auto& rec : log) rec.impact_factor.array() *= truth[s].array();
      per_site.push_back(std::move(log));
    }
    const auto records = fleet::merge_site_records(std::move(per_site));
    const auto fitter = [&](const std::vector<records::WimRecord>& corrected) {
      fleet::OnlineFitOptions o;
      o.marginal.sampler.particles = a.particles;
      o.marginal.sampler.threads = a.threads;
      o.marginal.sampler.seed = base + 7;
      auto fit = fleet::make_online_fit(sites, o);
      fleet::ReplayOptions replay;
      replay.final_sweeps = o.default_final_sweeps();
      fleet::replay(*fit, corrected, replay);
      return fit;
    };
    discrepancy::CalibrationOptions o;
    o.draws.threads = a.threads;
    o.draws.seed = base + 9;
    const auto done = discrepancy::fit_with_sensor_calibration(
        records, {Eigen::VectorXd::Ones(16), Eigen::VectorXd::Ones(8)}, fitter, o);
    double net_z2 = 0.0, net_max = 0.0;
    int net_gains = 0;
    for (std::size_t s = 0; s < sites.size(); ++s) {
      for (Eigen::Index j = 0; j < truth[s].size(); ++j) {
        const double z = (done.gains[s][j] - truth[s][j]) / done.se[s][j];
        net_z2 += z * z;
        net_max = std::max(net_max, std::abs(z));
        ++net_gains;
      }
    }
    z2 += net_z2;
    gains += net_gains;
    largest = std::max(largest, net_max);
    rounds += static_cast<long>(done.rounds.size());
    unconverged += done.converged ? 0 : 1;
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::cout << std::setw(7) << r + 1 << std::setw(8) << done.rounds.size() << (done.converged ? " " : "*") << std::fixed
              << std::setprecision(3) << std::setw(9) << net_z2 / net_gains << std::setw(9) << net_max << std::setw(14)
              << std::setprecision(4) << done.gains[0][4] << " +- " << done.se[0][4] << std::setw(17) << done.gains[1].mean()
              << std::setw(12) << std::setprecision(1) << secs << std::endl;
  }
  const double mean_z2 = z2 / static_cast<double>(gains);
  const double half = 3.09 * std::sqrt(2.0 / static_cast<double>(gains));
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << std::fixed << std::setprecision(3) << "\n" << a.networks << " networks of 2 sites x " << a.trucks
            << " trucks, " << gains << " gains: mean z^2 " << mean_z2 << " (reference 1, 99.8 % band " << 1.0 - half
            << " to " << 1.0 + half << "), largest |z| " << largest << ", EM fits per network "
            << std::setprecision(2) << static_cast<double>(rounds) / a.networks << " (" << unconverged
            << " not converged), " << std::setprecision(0) << secs << " s\n";
  if (a.check && std::abs(mean_z2 - 1.0) > half) {
    std::cout << "FAIL: the gains' standard errors are not calibrated (mean z^2 outside the band)\n";
    return 1;
  }
  return 0;
}
