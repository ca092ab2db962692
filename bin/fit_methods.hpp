// The two ways `fit` explores the posterior, behind one shape: records in, posterior draws out,
// progress to an optional stream.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <ostream>
#include <vector>

#include <boost/program_options.hpp>

#include <string>

#include "fleet/online_fit.hpp"
#include "fleet/posterior_cloud.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/wim_log.hpp"
#include "site/site.hpp"

namespace ssrfleet::cli {

// The SMC defaults are the cores' own, so `fit` and the library cannot drift apart.
struct FitFlags {
  // The model fitted (model/model_spec.hpp): "base", or effects such as tyre_damping+sensor_gain:sensor=11.
  std::string model = "base";
  std::string core = "marginal";  // marginal (default) | latent; latent when a model has effects
  bool core_given = false;
  long particles = 1024;
  int threads = 0;  // 0 = all cores
  int older_sweeps = fleet::FleetSmc::Options{}.older_sweeps;  // latent core
  // After the last truck, and per move phase at most: the marginal core's defaults, replaced by
  // the latent core's when that core is chosen and the flag was not given.
  int final_sweeps = fleet::MarginalSmc::Options{}.sampler.schedule.final_sweeps;
  bool final_sweeps_given = false;
  double cess_target = fleet::MarginalSmc::Options{}.sampler.tempering.cess_target;
  int max_sweeps = fleet::MarginalSmc::Options{}.sampler.schedule.max_sweeps;
  bool max_sweeps_given = false;
  long iterations = 20000;  // mcmc
  long burn_in = 5000;      // mcmc
  long thin = 10;           // mcmc
  int chains = 4;           // mcmc: independent chains, each of `iterations` sweeps
  int runs = 1;             // smc: independent runs pooled (fleet/smc_runs.hpp)
  bool verbose = false;     // one line per tempering step
  // fit --checkpoint DIR (io/fit_checkpoint.hpp): resume from DIR's checkpoint if there is one, and
  // write one every checkpoint_every_s seconds of fitting (or every checkpoint_every_trucks trucks).
  std::string checkpoint_dir;
  double checkpoint_every_s = 600.0;
  long checkpoint_every_trucks = 0;  // 0: by time only

  void add_to(boost::program_options::options_description& desc);
};

// extension: the model's effects (null for the base model); fit_smc fits them on the latent core.
fleet::PosteriorCloud fit_smc(const site::Site& site, const std::vector<records::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress,
                              const fleet::ModelExtension* extension = nullptr);
// One fleet over several sites (fleet/joint_sites.hpp): a record's `site` indexes `sites`; the
// marginal core only (UsageError for options that need the latent one).
fleet::PosteriorCloud fit_smc(const std::vector<const site::Site*>& sites, const std::vector<records::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress);
// The same, handing back the fit itself (what sensor calibration draws the trucks' latents from).
std::unique_ptr<fleet::OnlineFit> fit_smc_online(const std::vector<const site::Site*>& sites,
                                                 const std::vector<records::WimRecord>& records, const FitFlags& flags,
                                                 std::uint64_t seed, std::ostream* progress);
fleet::PosteriorCloud fit_mcmc(const site::Site& site, const std::vector<records::WimRecord>& records,
                               const FitFlags& flags, std::uint64_t seed, std::ostream* progress,
                               const fleet::ModelExtension* extension = nullptr);

// One independent posterior per vehicle class of `records` (an unlabelled log is one class with the
// empty label and the seed itself), each fitted by fit_class(class records, fleet::class_seed(seed,
// label)), written as one posterior file to `out` ('-' = stdout). Returns the classes' posteriors
// (sorted by label).
fleet::ClassPosteriors fit_classes_to_file(const std::vector<records::WimRecord>& records, std::uint64_t seed, const std::string& out,
                         std::ostream* progress,
                         const std::function<fleet::PosteriorCloud(const std::vector<records::WimRecord>&, std::uint64_t)>& fit_class);

}  // namespace ssrfleet::cli
