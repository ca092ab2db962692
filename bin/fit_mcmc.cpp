#include <algorithm>
#include <iomanip>

#include "fit_methods.hpp"
#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_cloud.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

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
  std::string why;
  if (!o.IsValid(&why)) throw UsageError(why);
  const fleet::BatchMcmcResult r = fleet::run_batch_mcmc(site, records, o);

  return fleet::to_posterior_cloud(r, site, records, extension);
}

}  // namespace ssrfleet::cli
