// A long reference run of the batch MCMC: the posterior mean, sd and chain ESS
// of the 7 hyperparameters on one of the preset fleets (fleet_presets.hpp, data seed 1, as
// ratio_benchmark simulates it), with default options (interweaving, best-fit starts, lateral
// jumps every 5th sweep), to judge an SMC fit against when ratio_benchmark's own chain is too short
// or was run before a fix of the MCMC. Writes one JSON file; says whether every ESS reached 1,000.
//
//   mcmc_reference_benchmark [--fleet table1|second] [--trucks 1000] [--iterations 45000]
//                            [--burn-in 5000] [--seed 7] [--json FILE]
//                            [--interweave-stiffness 0|1] [--joint-jump-every J]
// The last two override BatchMcmcOptions' defaults, to measure those options side by side.
#include <cmath>
#include <fstream>
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet_presets.hpp"
#include "run_info.hpp"
#include "site/road_source.hpp"
#include "util/effective_sample_size.hpp"

using namespace ssrfleet;

int main(int argc, char** argv) {
  std::string fleet_name = "table1", json_path;
  int trucks = 1000, iterations = 45000, burn_in = 5000;
  std::uint64_t seed = 7;
  fleet::BatchMcmcOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--fleet") fleet_name = next();
    else if (a == "--trucks") trucks = std::stoi(next());
    else if (a == "--iterations") iterations = std::stoi(next());
    else if (a == "--burn-in") burn_in = std::stoi(next());
    else if (a == "--seed") seed = std::stoull(next());
    else if (a == "--json") json_path = next();
    else if (a == "--interweave-stiffness") o.interweave_stiffness = std::stoi(next()) != 0;
    else if (a == "--joint-jump-every") o.joint_jump_every = std::stoi(next());
    else {
      std::cerr << "usage: mcmc_reference_benchmark [--fleet " << bench::fleet_preset_names()
                << "] [--trucks N] [--iterations I] [--burn-in B] [--seed S] [--json FILE]"
                   " [--interweave-stiffness 0|1] [--joint-jump-every J]\n";
      return a == "--help" ? 0 : 64;
    }
  }
  const auto preset = bench::find_fleet_preset(fleet_name);
  if (!preset || trucks < 2 || burn_in < 0 || iterations <= burn_in + 100) {
    std::cerr << "mcmc_reference_benchmark: unknown fleet, or trucks < 2, or iterations not above burn-in + 100\n";
    return 64;
  }
  const site::Site site(site::load_road(preset->road), site::SiteOptions{});
  const fleet::SimulatedLog log = bench::simulate_preset(site, *preset, trucks, 1);
  o.iterations = iterations;
  o.burn_in = burn_in;
  o.seed = seed;
  o.threads = 2;
  o.progress_every = 5000;
  o.progress = [](const fleet::BatchMcmcProgress& p) {
    std::cerr << "  MCMC sweep " << p.iteration << "/" << p.iterations << ", " << p.seconds << " s\n";
  };
  const double load_before = bench::load_average_1min();
  const fleet::BatchMcmcResult r = fleet::run_batch_mcmc(site, log.records, o);

  nlohmann::json j;
  j["benchmark"] = "mcmc_reference";
  j["fleet"] = preset->name;
  j["road"] = preset->road;
  j["trucks"] = trucks;
  j["iterations"] = iterations;
  j["burn_in"] = burn_in;
  j["seed"] = seed;
  j["lateral_jump_every"] = o.lateral_jump_every;
  j["joint_jump_every"] = o.joint_jump_every;
  j["interweave_stiffness"] = o.interweave_stiffness;
  j["integrator_passes"] = r.integrator_passes;
  j["lateral_jump_acceptance"] = r.lateral_jump_acceptance;
  j["joint_jump_acceptance"] = r.joint_jump_acceptance;
  j["ancillary_k_acceptance"] = r.ancillary_k_acceptance;
  j["ancillary_kt_acceptance"] = r.ancillary_kt_acceptance;
  j["wall_s"] = r.wall_seconds;
  j["load_1min_before_after"] = {load_before, bench::load_average_1min()};
  j["commit"] = bench::run_command("git rev-parse --short HEAD 2>/dev/null");
  j["written_utc"] = bench::utc_now();
  double min_ess = INFINITY;
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const Eigen::VectorXd c = r.theta_draws.col(h);
    const double mean = c.mean(), sd = std::sqrt((c.array() - mean).square().mean());
    const double ess = chain_effective_sample_size(c);
    min_ess = std::min(min_ess, ess);
    const std::string name(fleet::kHyperNames[static_cast<std::size_t>(h)]);
    j["posterior"][name] = {{"mean", mean}, {"sd", sd}, {"ess", ess}, {"truth", preset->truth()[static_cast<std::size_t>(h)]}};
    std::cout << name << " " << mean << " sd " << sd << " ess " << ess << "\n";
  }
  j["min_ess"] = min_ess;
  j["ess_at_least_1000"] = min_ess >= 1000.0;
  if (!json_path.empty()) std::ofstream(json_path) << j.dump(2) << "\n";
  std::cout << "passes " << r.integrator_passes << ", lateral jump acceptance " << r.lateral_jump_acceptance
            << ", joint jump acceptance " << r.joint_jump_acceptance << "\n";
  std::cout << "min ESS " << min_ess << (min_ess >= 1000.0 ? " (>= 1000)" : " (BELOW 1000)") << ", wall "
            << r.wall_seconds << " s\n";
  return min_ess >= 1000.0 ? 0 : 3;
}
