#include <algorithm>
#include <iomanip>
#include <ostream>

#include "fit_methods.hpp"
#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_chains.hpp"
#include "fleet/batch_mcmc_cloud.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {
// The chains' diagnostics, one line a parameter (R̂ above 1.01 is the usual sign of chains that
// have not mixed: Vehtari et al. 2021).
void print_convergence(std::ostream& out, const fleet::PosteriorCloud& cloud) {
  out << "fit (mcmc): " << cloud.chains << " chains; R-hat, bulk-ESS, tail-ESS, MCSE of mean / q05 / q95:\n";
  bool unmixed = false;
  for (const auto& p : cloud.convergence) {
    out << "  " << std::left << std::setw(10) << p.name << std::right << std::fixed << std::setprecision(4)
        << " R-hat " << p.rhat << "  ESS " << std::fixed << std::setprecision(0) << p.ess_bulk << " / " << p.ess_tail
        << "  MCSE " << std::defaultfloat << std::setprecision(3) << p.mcse_mean << " / " << p.mcse_q05 << " / "
        << p.mcse_q95 << "\n";
    unmixed = unmixed || p.rhat > 1.01;
  }
  if (unmixed) out << "fit (mcmc): warning: R-hat above 1.01: the chains disagree; run more --iterations\n";
}
}  // namespace

fleet::PosteriorCloud fit_mcmc(const site::Site& site, const std::vector<records::WimRecord>& records,
                               const FitFlags& flags, std::uint64_t seed, std::ostream* progress,
                               const fleet::ModelExtension* extension) {
  fleet::BatchMcmcOptions o;
  o.extension = extension;
  if (flags.iterations > 100'000'000 || flags.burn_in > flags.iterations || flags.thin < 1) {
    throw UsageError("--iterations / --burn-in / --thin: need 1 <= thin, burn-in < iterations <= 1e8");
  }
  o.iterations = static_cast<int>(flags.iterations);
  o.burn_in = static_cast<int>(flags.burn_in);
  o.thin = static_cast<int>(flags.thin);
  o.seed = seed;
  if (progress) {
    o.progress_every = std::max(1, o.iterations / 50);
    o.progress = [progress](const fleet::BatchMcmcProgress& p) {
      *progress << "fit (mcmc): sweep " << p.iteration << "/" << p.iterations << (p.burning_in ? " (burn-in)" : "")
                << ", latent acceptance " << std::fixed << std::setprecision(2) << p.latent_acceptance
                << ", (Z, sigma_z) acceptance " << p.z_acceptance << ", " << std::setprecision(1) << p.seconds
                << " s\n";
    };
  }
  o.threads = flags.threads;
  fleet::BatchMcmcChainsOptions chains;
  chains.chain = o;
  chains.chains = flags.chains;
  std::string why;
  if (!chains.IsValid(&why)) throw UsageError("--chains / MCMC options: " + why);
  const auto results = fleet::run_batch_mcmc_chains(site, records, chains);
  fleet::PosteriorCloud cloud = fleet::to_posterior_cloud(results, site, records, extension);
  if (progress != nullptr && !cloud.convergence.empty()) print_convergence(*progress, cloud);
  return cloud;
}

}  // namespace ssrfleet::cli
