#include "discrepancy/posterior_draws.hpp"

#include <string>

#include "model/extended_forward.hpp"
#include "smc/parallel.hpp"
#include "smc/resampling.hpp"
#include "util/errors.hpp"

namespace ssrfleet::discrepancy {

PosteriorDraws posterior_draws(const site::Site& site, const fleet::FleetSmc& fit, int draws, std::uint64_t seed,
                               int threads) {
  const fleet::FleetTarget& target = fit.target();
  const Eigen::Index n = target.kept_trucks();
  if (draws < 1) throw UsageError("posterior checks: draws must be at least 1");
  const int M = site.sensors();
  PosteriorDraws out;
  out.observed.resize(M, n);
  out.speed_mps.resize(n);
  out.sprung_mass_kg.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto t = static_cast<std::size_t>(i);
    out.observed.col(i) = target.kept_observed_if()[t];
    out.speed_mps[i] = target.kept_speed_mps()[t];
    out.sprung_mass_kg[i] = target.kept_sprung_mass_kg()[t];
  }
  smc::Rng rng = smc::RngFactory(seed).child(0x636865636bULL /* "check" */).stream(0);
  const auto chosen = smc::systematic_resampling(fit.sampler().weights(), draws, rng);
  out.model_if.assign(chosen.size(), Eigen::MatrixXd());
  out.lateral_m.assign(chosen.size(), Eigen::VectorXd());
  out.sigma_if.assign(chosen.size(), 0.0);
  out.stiffness_pit.assign(chosen.size(), Eigen::VectorXd());
  out.tyre_stiffness_pit.assign(chosen.size(), Eigen::VectorXd());
  const fleet::ModelExtension* extension = target.extension();
  const smc::ParallelFor parallel(threads);
  parallel(static_cast<Eigen::Index>(chosen.size()), [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index d = begin; d < end; ++d) {
      const Eigen::Index p = chosen[static_cast<std::size_t>(d)];
      const Eigen::VectorXd psi = target.psi().col(p);
      std::vector<fleet::ExtendedPass> passes;
      Eigen::VectorXd lateral(n), pit(n), tyre_pit(n);
      const double K = target.theta()(fleet::kK, p), sigma_k = target.theta()(fleet::kSigmaK, p);
      const double Kt = target.theta()(fleet::kKt, p), sigma_kt = target.theta()(fleet::kSigmaKt, p);
      for (Eigen::Index i = 0; i < n; ++i) {
        const double* x = target.latents().col(p).data() + 3 * i;
        lateral[i] = x[fleet::kLateral];
        pit[i] = extension != nullptr ? extension->stiffness_cdf(psi.data(), x[fleet::kStiffness], K, sigma_k)
                                      : fleet::normal_cdf((x[fleet::kStiffness] - K) / sigma_k);
        tyre_pit[i] = fleet::normal_cdf((x[fleet::kTyreStiffness] - Kt) / sigma_kt);
        passes.push_back({fleet::base_pass(site, out.speed_mps[i], out.sprung_mass_kg[i], x[fleet::kStiffness],
                                           x[fleet::kTyreStiffness], lateral[i]),
                          psi.data()});
      }
      Eigen::ArrayXXd f(M, n);
      fleet::simulate_passes(site, extension, passes, f);
      const auto slot = static_cast<std::size_t>(d);
      out.model_if[slot] = f.matrix();
      out.lateral_m[slot] = lateral;
      out.sigma_if[slot] = target.theta()(fleet::kSigmaIf, p);
      out.stiffness_pit[slot] = pit;
      out.tyre_stiffness_pit[slot] = tyre_pit;
    }
  });
  return out;
}

}  // namespace ssrfleet::discrepancy
