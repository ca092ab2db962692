#include <cmath>
#include <iomanip>

#include "fit_methods.hpp"
#include "fleet/batch_mcmc.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

fleet::PosteriorCloud fit_mcmc(const site::Site& site, const std::vector<io::WimRecord>& records,
                               const FitFlags& flags, std::uint64_t seed, std::ostream* progress) {
  fleet::BatchMcmcOptions o;
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

  fleet::PosteriorCloud c;
  c.method = "mcmc";
  c.theta = r.theta_draws.transpose();
  c.weights = Eigen::ArrayXd::Constant(c.theta.cols(), 1.0 / static_cast<double>(c.theta.cols()));
  for (const auto& rec : records) {
    c.speed_mps.push_back(rec.speed_mps);
    c.sprung_mass_kg.push_back(rec.sprung_mass_kg);
  }
  c.site_fingerprint = site.fingerprint();
  c.road_name = site.surface().name;
  c.sensors = site.sensors();
  c.lateral_min_m = site.lateral_min_m();
  c.lateral_max_m = site.lateral_max_m();
  c.trucks_seen = static_cast<long>(records.size());
  c.ess = static_cast<double>(c.theta.cols());  // draws kept; autocorrelation not accounted for
  c.log_evidence = NAN;
  return c;
}

}  // namespace ssrfleet::cli
