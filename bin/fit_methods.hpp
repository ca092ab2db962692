// The two ways `fit` explores the posterior, behind one shape: records in, posterior draws out,
// progress to an optional stream.
#pragma once

#include <cstdint>
#include <ostream>
#include <vector>

#include <boost/program_options.hpp>

#include "fleet/fleet_smc.hpp"
#include "fleet/posterior_cloud.hpp"
#include "io/wim_log.hpp"
#include "site/site.hpp"

namespace ssrfleet::cli {

// The SMC defaults are FleetSmc's own, so `fit` and the library cannot drift apart.
struct FitFlags {
  long particles = 1024;
  int threads = 0;  // 0 = all cores
  int older_sweeps = fleet::FleetSmc::Options{}.older_sweeps;
  int final_sweeps = fleet::FleetSmc::Options{}.final_sweeps;  // after the last truck (FleetSmc::rejuvenate)
  long window = 0;  // bounded memory (see stream --window)
  double cess_target = fleet::FleetSmc::Options{}.sampler.tempering.cess_target;
  int max_sweeps = fleet::FleetSmc::Options{}.sampler.mh.max_steps;
  long iterations = 20000;  // mcmc
  long burn_in = 5000;      // mcmc
  long thin = 10;           // mcmc
  bool verbose = false;     // one line per tempering step

  void add_to(boost::program_options::options_description& desc);
};

fleet::PosteriorCloud fit_smc(const site::Site& site, const std::vector<records::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress);
fleet::PosteriorCloud fit_mcmc(const site::Site& site, const std::vector<records::WimRecord>& records,
                               const FitFlags& flags, std::uint64_t seed, std::ostream* progress);

}  // namespace ssrfleet::cli
