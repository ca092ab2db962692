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

struct FitFlags {
  long particles = 1024;
  int threads = 0;  // 0 = all cores
  int older_sweeps = 2;
  int final_sweeps = fleet::FleetSmc::Options{}.final_sweeps;  // after the last truck (FleetSmc::rejuvenate)
  long window = 0;  // bounded memory (see stream --window)
  double cess_target = 0.9;
  int max_sweeps = 5;
  long iterations = 20000;  // mcmc
  long burn_in = 5000;      // mcmc
  long thin = 10;           // mcmc
  bool verbose = false;     // one line per tempering step

  void add_to(boost::program_options::options_description& desc);
};

fleet::PosteriorCloud fit_smc(const site::Site& site, const std::vector<io::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress);
fleet::PosteriorCloud fit_mcmc(const site::Site& site, const std::vector<io::WimRecord>& records,
                               const FitFlags& flags, std::uint64_t seed, std::ostream* progress);

}  // namespace ssrfleet::cli
