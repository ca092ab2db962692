#include <algorithm>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>
#include <filesystem>
#include <functional>
#include <optional>

#include <boost/math/distributions/chi_squared.hpp>

#include "cli_common.hpp"
#include "process_ranks.hpp"
#include "fit_methods.hpp"
#include "fleet/online_fit.hpp"
#include "fleet/joint_sites.hpp"
#include "fleet/replay.hpp"
#include "fleet/smc_runs.hpp"
#include "io/fit_checkpoint.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace po = boost::program_options;

void FitFlags::add_to(po::options_description& desc) {
  po::options_description smc("SMC options");
  smc.add_options()
      ("model", po::value(&model)->value_name("SPEC")->default_value(model),
       "the model to fit: base, or effects joined by '+', each NAME or NAME:param=value,... (a parameter given is "
       "fixed, one left out is fitted), e.g. tyre_damping+sensor_gain:sensor=11; second_class, tyre_damping, unsprung_mass, "
       "suspension_damping and a gain on a given sensor (sensor_gain:sensor=N) fit on the marginal core, the others "
       "and compositions on the latent core (speed_bias also on the marginal core with --core marginal; ssrfleet "
       "effects lists them)")
      ("core", po::value(&core)->value_name("CORE")->default_value(core),
       "inference core: marginal (each truck's latents integrated out in a table built on arrival; IBIS over the "
       "7 hyperparameters, cost per truck flat in n) or latent (every truck's latents in every particle; cost per "
       "truck grows with n)")
      ("particles", po::value(&particles)->value_name("N")->default_value(particles), "number of particles P (>= 2)")
      ("threads", po::value(&threads)->value_name("N")->default_value(threads),
       "worker threads; 0 = all cores (results do not depend on it)")
      ("final-sweeps", po::value(&final_sweeps)->value_name("N")->default_value(final_sweeps),
       "MCMC sweeps after the last truck: the same posterior, less seed-to-seed error; the marginal core's posterior "
       "pools every sweep's cloud (latent core: 50 unless given, not pooled)")
      ("cess", po::value(&cess_target)->value_name("X")->default_value(cess_target, shortest_text(cess_target)),
       "conditional-ESS target of each tempering step, in (0, 1)")
      ("max-sweeps", po::value(&max_sweeps)->value_name("N")->default_value(max_sweeps),
       "MCMC sweeps per move phase at most (latent core: per tempering step, 5 unless given)")
      ("older-sweeps", po::value(&older_sweeps)->value_name("N")->default_value(older_sweeps),
       "latent core: MH sweeps over every older truck's latents after each new truck (0 = off)")
      ("checkpoint", po::value(&checkpoint_dir)->value_name("DIR"),
       "a directory for the fit's checkpoints (marginal core; made if missing): a fit that stopped (a killed job, a "
       "lost MPI rank) resumes from its last one with the same result, also on another number of ranks; a log grown "
       "since goes on from it")
      ("checkpoint-every", po::value(&checkpoint_every_s)->value_name("SECONDS")->default_value(checkpoint_every_s, "600"),
       "seconds of fitting between checkpoints (one is also written after the last truck)")
      ("checkpoint-every-trucks", po::value(&checkpoint_every_trucks)->value_name("N")->default_value(checkpoint_every_trucks),
       "also a checkpoint every this many trucks (0: by time only)")
      ("runs", po::value(&runs)->value_name("R")->default_value(runs),
       "independent SMC runs (run 1 with --seed itself, the others from seeds derived from it), one after the "
       "other, pooled into one posterior; their R-hat, equivalent ESS and the MCSE of each mean and 5 %/95 % "
       "quantile from their spread are printed and kept in the posterior file (R from 2 to 64; 1: one run)")
      ("verbose", po::bool_switch(&verbose),
       "print the move schedule, then every tempering step (phi, ESS, each scheduled move's runs and acceptance, jump "
       "per block)");
  po::options_description mcmc("MCMC options (--method mcmc)");
  mcmc.add_options()
      ("chains", po::value(&chains)->value_name("N")->default_value(chains),
       "independent chains from over-dispersed starts, run side by side; their R-hat, bulk- and tail-ESS and "
       "MCSE are printed and kept in the posterior file")
      ("iterations", po::value(&iterations)->value_name("N")->default_value(iterations), "MCMC sweeps per chain")
      ("burn-in", po::value(&burn_in)->value_name("N")->default_value(burn_in),
       "sweeps discarded (proposal adaptation happens here)")
      ("thin", po::value(&thin)->value_name("N")->default_value(thin), "keep every N-th sweep");
  desc.add(smc).add(mcmc);
}

fleet::OnlineFitOptions online_fit_options(const FitFlags& flags, std::uint64_t seed,
                                           const fleet::ModelExtension* extension) {
  fleet::OnlineFitOptions o;
  if (flags.core != "latent" && flags.core != "marginal") {
    throw UsageError("--core must be marginal or latent, not '" + flags.core + "'");
  }
  // --core as given (or its default for the base model, which every core carries); a model with
  // effects takes the core chosen for it unless --core names one.
  std::optional<fleet::Core> requested;
  if (flags.core_given || extension == nullptr) requested = flags.core == "latent" ? fleet::Core::kLatent : fleet::Core::kMarginal;
  try {
    o.core = fleet::choose_core(extension, requested);
  } catch (const UsageError& e) {  // the marginal core asked for a model it does not carry
    throw UsageError("--model " + extension->name() + ": " + e.what() + ", or --method mcmc");
  }
  o.extension = extension;
  // Under mpirun (ssrfleet-mpi) the ranks share the marginal core's trucks; the latent core keeps
  // every truck's latents in every particle and runs on one process.
  const util::Ranks& ranks = process_ranks();
  if (ranks.size() > 1 && o.core != fleet::OnlineFitOptions::Core::kMarginal) {
    throw UsageError("the latent core (--core latent, or a --model it alone carries) runs on one process; only the marginal "
                     "core spreads over MPI ranks: run ssrfleet fit without mpirun");
  }
  o.marginal.target.ranks = &ranks;
  if (!flags.checkpoint_dir.empty()) {
    if (o.core != fleet::OnlineFitOptions::Core::kMarginal) {
      throw UsageError("--checkpoint: checkpoints of a fit are the marginal core's; the latent core (--core latent, "
                       "or a --model it alone carries) fits without them");
    }
    if (!(flags.checkpoint_every_s > 0.0)) throw UsageError("--checkpoint-every must be > 0 seconds");
    if (flags.checkpoint_every_trucks < 0) throw UsageError("--checkpoint-every-trucks must be >= 0");
    // Made if missing (its parent must exist: a mistyped path should not grow a tree of folders).
    std::error_code ec;
    std::filesystem::create_directory(flags.checkpoint_dir, ec);
    if (!std::filesystem::is_directory(flags.checkpoint_dir, ec)) {
      if (std::filesystem::exists(flags.checkpoint_dir, ec)) {
        throw UsageError("--checkpoint '" + flags.checkpoint_dir + "' is a file, not a directory");
      }
      throw MissingInputError("--checkpoint '" + flags.checkpoint_dir + "': cannot make the directory (does its parent exist?)");
    }
  }
  if (flags.final_sweeps < 0) throw UsageError("--final-sweeps must be >= 0");
  if (flags.max_sweeps < 1) throw UsageError("--max-sweeps must be >= 1");
  o.sampler().particles = flags.particles;
  o.sampler().threads = flags.threads > 0 ? flags.threads : smc::TemperedSampler::Options::default_threads();
  o.sampler().seed = seed;
  o.sampler().tempering.cess_target = flags.cess_target;
  if (o.core == fleet::OnlineFitOptions::Core::kMarginal || flags.max_sweeps_given) o.sampler().schedule.max_sweeps = flags.max_sweeps;
  o.latent.older_sweeps = flags.older_sweeps;
  std::string why;
  if (!o.sampler().IsValid(&why)) throw UsageError(why);
  return o;
}

namespace {
std::unique_ptr<fleet::OnlineFit> fit_smc_on(const std::vector<const site::Site*>& sites,
                                             const std::vector<records::WimRecord>& records, const FitFlags& flags,
                                             std::uint64_t seed, std::ostream* progress,
                                             const fleet::ModelExtension* extension) {
  fleet::OnlineFitOptions o = online_fit_options(flags, seed, extension);
  const int final_sweeps = flags.final_sweeps_given ? flags.final_sweeps : o.default_final_sweeps();
  auto smc = fleet::make_online_fit(sites, o);
  const std::size_t n = records.size();
  const util::Ranks& ranks = process_ranks();
  const std::string checkpoint = flags.checkpoint_dir.empty() ? std::string()
                                 : io::fit_checkpoint_path(flags.checkpoint_dir, seed, fleet::sites_fingerprint(sites));
  // What a checkpoint must have been made with, besides the sites and the seed.
  std::ostringstream checkpoint_options;
  checkpoint_options << "particles=" << o.sampler().particles << " cess=" << shortest_text(o.sampler().tempering.cess_target)
                     << " max_sweeps=" << o.sampler().schedule.max_sweeps;
  std::size_t resumed = 0;
  if (!checkpoint.empty()) {
    resumed = io::read_fit_checkpoint(checkpoint, *smc, records, checkpoint_options.str());
    if (resumed > 0 && progress) *progress << "fit: resumed from " << checkpoint << " at truck " << resumed << "/" << n << "\n";
  }
  io::check_ranks_agree(ranks, records, resumed);
  io::CheckpointClock checkpoint_clock(ranks, n, flags.checkpoint_every_s, flags.checkpoint_every_trucks);
  if (progress && flags.verbose)
    *progress << "fit: move schedule (" << smc->core() << " core)\n" << smc->sampler().options().schedule.describe();
  fleet::ReplayOptions replay;
  replay.final_sweeps = final_sweeps;
  std::function<void(std::size_t, const smc::StageSummary&, const fleet::OnlineFit&)> report;
  if (progress) {
    report = [&](std::size_t t, const smc::StageSummary& stage, const fleet::OnlineFit& fit) {
      double acc = 0.0;
      int blocks = 0, moves = 0;
      for (const auto& step : stage.steps) {
        for (double a : step.mh.acceptance) acc += a, ++blocks;
        moves += step.mh.sweeps > 0 ? 1 : 0;
      }
      *progress << "fit: truck " << (t + 1) << "/" << n << " " << records[t].truck_id << ": " << stage.steps.size()
                << " steps, " << moves << " move phases, ESS " << std::fixed << std::setprecision(0)
                << fit.sampler().ess() << "/" << flags.particles;
      if (blocks) *progress << ", acceptance " << std::setprecision(2) << acc / blocks;
      *progress << ", " << std::setprecision(3) << stage.wall_time_s << " s";
      const std::string note = fit.note();
      *progress << (note.empty() ? "" : "; ") << note << "\n";
      progress->unsetf(std::ios::floatfield);
      if (flags.verbose) *progress << stage.FullReport();
    };
    // Announced first: on a long log they take a while (one pass over every truck per particle each).
    replay.before_final_sweeps = [&](int sweeps) {
      *progress << "fit: " << sweeps << " final sweeps at phi = 1 (" << smc->core() << " core) ..." << std::flush;
    };
  }
  // Truck stages that ran no move: the part of a truck's cost that more ranks do not shrink (its
  // own ℓ for every particle, on its rank; the reweighting), for the summary line below.
  long plain_stages = 0, moved_stages = 0, sweeps = 0;
  double plain_stage_s = 0.0, moved_stage_s = 0.0;
  replay.after_record = [&](std::size_t t, const smc::StageSummary& stage, const fleet::OnlineFit& fit) {
    if (report) report(t, stage, fit);
    long stage_sweeps = 0;
    for (const auto& step : stage.steps) stage_sweeps += step.mh.sweeps;
    sweeps += stage_sweeps;
    (stage_sweeps > 0 ? moved_stages : plain_stages) += 1;
    (stage_sweeps > 0 ? moved_stage_s : plain_stage_s) += stage.wall_time_s;
    if (!checkpoint.empty() && checkpoint_clock.due(t)) {
      // A checkpoint that cannot be written (a full disk) is insurance lost, not the fit: warn and
      // go on (only rank 0 writes, so only it can fail, after its part in the collectives).
      try {
        io::write_fit_checkpoint(checkpoint, fit, ranks, checkpoint_options.str());
      } catch (const IoError& e) {
        std::cerr << "ssrfleet fit: warning: checkpoint after truck " << (t + 1) << " not written: " << e.what()
                  << "; the fit goes on (the last checkpoint, if any, is still whole)\n";
      }
      checkpoint_clock.restart();
    }
  };
  const fleet::ReplaySummary done = fleet::replay(*smc, records, replay);
  if (progress && done.final_sweeps > 0) {
    *progress << " done, " << std::fixed << std::setprecision(3) << done.final_s << " s\n";
    progress->unsetf(std::ios::floatfield);
  }
  // Where the time went, and what the ranks exchanged (the MPI scaling figures come from this
  // line). Every rank's table time is gathered first (a collective, so every
  // rank takes part, printing or not).
  std::vector<std::string> each;
  const std::optional<double> table_s = smc->table_seconds();
  if (table_s && ranks.size() > 1) each = ranks.gather(std::to_string(*table_s), 0);
  const util::Ranks::Traffic sent = ranks.traffic();
  if (table_s && progress) {
    const double tables = *table_s, total = done.replay_s + done.final_s;
    *progress << std::fixed << std::setprecision(2) << "fit: " << ranks.size() << " rank(s) x " << o.sampler().threads
              << " thread(s): " << total << " s, of which tables " << tables << " s (rank 0's trucks), stages and moves "
              << total - tables << " s (" << moved_stages << " truck stages with " << sweeps << " sweeps in all "
              << moved_stage_s << " s; " << done.final_sweeps << " final sweeps " << done.final_s << " s; "
              << plain_stages << " truck stages without moves " << plain_stage_s << " s, " << std::setprecision(3)
              << (plain_stages > 0 ? 1e3 * plain_stage_s / static_cast<double>(plain_stages) : 0.0) << " ms each)";
    if (!each.empty()) {
      std::vector<double> t;
      for (const std::string& e : each) t.push_back(std::stod(e));
      *progress << "; tables per rank " << *std::min_element(t.begin(), t.end()) << " to "
                << *std::max_element(t.begin(), t.end()) << " s; rank 0 sent " << sent.bytes << " bytes in "
                << sent.calls << " collectives";
    }
    *progress << "\n";
    progress->unsetf(std::ios::floatfield);
  }
  // Printed even with --quiet: it is about the answer, not the progress.
  if (const std::string w = smc->warning(); !w.empty()) std::cerr << "ssrfleet fit: warning: " << w << "\n";
  return smc;
}
}  // namespace

namespace {
// The runs' diagnostics, one line a parameter (fleet/smc_runs.hpp). R-hat above 1.01 says the runs
// disagree by more than a tenth of a posterior sd or so: more particles or final sweeps are needed.
void print_run_convergence(std::ostream& out, const fleet::PosteriorCloud& cloud) {
  // R runs give the scatter's square to a χ²(R - 1)/(R - 1) factor, and the ESS with it.
  const double dof = static_cast<double>(cloud.chains - 1);
  const boost::math::chi_squared chi2(dof);
  out << "fit (smc): " << cloud.chains << " runs; R-hat, equivalent ESS, MCSE of mean / q05 / q95 (an equivalent "
      << "ESS from " << cloud.chains << " runs is within x" << std::setprecision(2) << boost::math::quantile(chi2, 0.05) / dof
      << " to x" << boost::math::quantile(chi2, 0.95) / dof << " of the true one, 90 %):\n";
  bool unmixed = false;
  for (const auto& p : cloud.convergence) {
    out << "  " << std::left << std::setw(10) << p.name << std::right << std::fixed << std::setprecision(4)
        << " R-hat " << p.rhat << "  ESS " << std::setprecision(0) << p.ess_equivalent << "  MCSE "
        << std::defaultfloat << std::setprecision(3) << p.mcse_mean << " / " << p.mcse_q05 << " / " << p.mcse_q95
        << "\n";
    unmixed = unmixed || p.rhat > 1.01;
  }
  if (unmixed) {
    out << "fit (smc): warning: R-hat above 1.01: the runs disagree; give more --particles or --final-sweeps\n";
  }
}

// `runs` independent fits (fleet::run_seed), pooled.
fleet::PosteriorCloud fit_smc_runs(const std::vector<const site::Site*>& sites,
                                   const std::vector<records::WimRecord>& records, const FitFlags& flags,
                                   std::uint64_t seed, std::ostream* progress, const fleet::ModelExtension* extension) {
  if (flags.runs < 1 || flags.runs > 64) throw UsageError("--runs must be from 1 to 64, not " + std::to_string(flags.runs));
  std::vector<fleet::PosteriorCloud> runs;
  for (int r = 0; r < flags.runs; ++r) {
    const std::uint64_t run_seed = fleet::run_seed(seed, r);
    if (progress && flags.runs > 1) *progress << "fit: run " << (r + 1) << "/" << flags.runs << ", seed " << run_seed << "\n";
    runs.push_back(fit_smc_on(sites, records, flags, run_seed, progress, extension)->cloud());
  }
  fleet::PosteriorCloud cloud = fleet::pool_runs(runs);
  if (progress && flags.runs > 1) print_run_convergence(*progress, cloud);
  return cloud;
}
}  // namespace

fleet::PosteriorCloud fit_smc(const site::Site& site, const std::vector<records::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress,
                              const fleet::ModelExtension* extension) {
  return fit_smc_runs({&site}, records, flags, seed, progress, extension);
}

fleet::PosteriorCloud fit_smc(const std::vector<const site::Site*>& sites, const std::vector<records::WimRecord>& records,
                              const FitFlags& flags, std::uint64_t seed, std::ostream* progress) {
  return fit_smc_runs(sites, records, flags, seed, progress, nullptr);
}

std::unique_ptr<fleet::OnlineFit> fit_smc_online(const std::vector<const site::Site*>& sites,
                                                 const std::vector<records::WimRecord>& records, const FitFlags& flags,
                                                 std::uint64_t seed, std::ostream* progress) {
  return fit_smc_on(sites, records, flags, seed, progress, nullptr);
}

}  // namespace ssrfleet::cli
