#include <chrono>
#include <iomanip>
#include <sstream>
#include <thread>

#include "cli_common.hpp"
#include "fit_methods.hpp"
#include "fleet/fleet_smc.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace po = boost::program_options;

void FitFlags::add_to(po::options_description& desc) {
  po::options_description smc("SMC options");
  smc.add_options()
      ("particles", po::value(&particles)->default_value(particles), "number of particles P (>= 2)")
      ("threads", po::value(&threads)->default_value(threads), "worker threads; 0 = all cores (results do not depend on it)")
      ("older-sweeps", po::value(&older_sweeps)->default_value(older_sweeps),
       "MH sweeps over every older truck's latents after each new truck (0 = off)")
      ("final-sweeps", po::value(&final_sweeps)->default_value(final_sweeps),
       "MH sweeps over every truck's latents and the hyperparameters after the last truck: the same posterior, "
       "less seed-to-seed error (n passes per particle each)")
      ("cess", po::value(&cess_target)->default_value(cess_target, shortest_text(cess_target)), "conditional-ESS target of each tempering step, in (0, 1)")
      ("max-sweeps", po::value(&max_sweeps)->default_value(max_sweeps), "MCMC sweeps per tempering step at most")
      ("window", po::value(&window)->default_value(window),
       "keep and move only the last W trucks' latents per particle; older ones as sufficient statistics (0 = exact)")
      ("verbose", po::bool_switch(&verbose), "report every tempering step (phi, ESS, acceptance and jump per block)");
  po::options_description mcmc("MCMC options (--method mcmc)");
  mcmc.add_options()
      ("iterations", po::value(&iterations)->default_value(iterations), "MCMC sweeps in all")
      ("burn-in", po::value(&burn_in)->default_value(burn_in), "sweeps discarded (proposal adaptation happens here)")
      ("thin", po::value(&thin)->default_value(thin), "keep every thin-th sweep");
  desc.add(smc).add(mcmc);
}

fleet::PosteriorCloud fit_smc(const site::Site& site, const std::vector<records::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress) {
  fleet::FleetSmc::Options o;
  o.sampler.particles = flags.particles;
  o.sampler.threads = flags.threads > 0 ? flags.threads : smc::TemperedSampler::Options::default_threads();
  o.sampler.seed = seed;
  o.sampler.tempering.cess_target = flags.cess_target;
  o.sampler.mh.max_steps = flags.max_sweeps;
  o.older_sweeps = flags.older_sweeps;
  if (flags.window < 0) throw UsageError("--window must be >= 0");
  if (flags.final_sweeps < 0) throw UsageError("--final-sweeps must be >= 0");
  o.window = flags.window;
  std::string why;
  if (!o.sampler.IsValid(&why)) throw UsageError(why);
  fleet::FleetSmc smc(site, o);
  const std::size_t n = records.size();
  const bool verbose_report = flags.verbose;
  for (std::size_t t = 0; t < n; ++t) {
    const auto& stage = smc.absorb(records[t]);
    if (progress) {
      double acc = 0.0;
      int blocks = 0;
      for (const auto& step : stage.steps) {
        for (double a : step.mh.acceptance) acc += a, ++blocks;
      }
      *progress << "fit: truck " << (t + 1) << "/" << n << " " << records[t].truck_id << ": " << stage.steps.size()
                << " steps, ESS " << std::fixed << std::setprecision(0) << smc.sampler().ess() << "/" << flags.particles
                << ", acceptance " << std::setprecision(2) << (blocks ? acc / blocks : 0.0) << ", "
                << std::setprecision(3) << stage.wall_time_s << " s\n";
      if (verbose_report) *progress << stage.FullReport();
    }
  }
  if (flags.final_sweeps > 0) {
    // Announced first: on a long log they take a while (n passes per particle each).
    if (progress) {
      *progress << "fit: " << flags.final_sweeps << " final sweeps over all " << smc.target().kept_trucks()
                << " trucks' latents and the hyperparameters ..." << std::flush;
    }
    const auto started = std::chrono::steady_clock::now();
    smc.rejuvenate(flags.final_sweeps);
    if (progress) {
      *progress << " done: acceptance " << std::fixed << std::setprecision(2) << smc.target().older_acceptance() << ", "
                << std::setprecision(3) << std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()
                << " s\n";
    }
  }
  return smc.cloud();
}

}  // namespace ssrfleet::cli
