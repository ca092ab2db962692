#include "fleet/batch_mcmc_residuals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "model/extended_forward.hpp"
#include "util/errors.hpp"
#include "vehicle/pass_integrator.hpp"

namespace ssrfleet::fleet::detail {

Observations gather(const site::Site& site, const std::vector<records::WimRecord>& records) {
  if (records.empty()) throw DataError("batch MCMC: no WIM records to fit");
  Observations obs;
  obs.trucks = static_cast<int>(records.size());
  obs.sensors = site.sensors();
  obs.speed_mps.resize(obs.trucks);
  obs.sprung_mass_kg.resize(obs.trucks);
  obs.impact_factor.resize(obs.sensors, obs.trucks);
  for (int n = 0; n < obs.trucks; ++n) {
    const records::WimRecord& r = records[static_cast<std::size_t>(n)];
    if (r.impact_factor.size() != obs.sensors) {
      throw DataError("batch MCMC: truck '" + r.truck_id + "' has " + std::to_string(r.impact_factor.size()) +
                      " impact factors but the site has " + std::to_string(obs.sensors) + " sensors");
    }
    if (!r.impact_factor.allFinite() || !(r.speed_mps > 0.0) || !(r.sprung_mass_kg > 0.0)) {
      throw DataError("batch MCMC: truck '" + r.truck_id +
                      "' has a non-finite impact factor or a non-positive speed or mass");
    }
    obs.speed_mps[n] = r.speed_mps;
    obs.sprung_mass_kg[n] = r.sprung_mass_kg;
    obs.impact_factor.col(n) = r.impact_factor.array();
  }
  return obs;
}

void ResidualEvaluator::evaluate(const std::vector<int>& which, const Eigen::ArrayXd& k, const Eigen::ArrayXd& kt,
                                 const Eigen::ArrayXd& z, const double* psi, Eigen::ArrayXd& ssr_out) {
  if (extension_ != nullptr && psi == nullptr) {
    throw UsageError("batch MCMC: the residuals of an extended model need its parameters (psi is null)");
  }
  constexpr Eigen::Index kBlock = vehicle::batch_block_trucks;
  constexpr Eigen::Index kChunk = 2048;  // a multiple of kBlock: bounds the work arrays
  static_assert(kChunk % kBlock == 0);
  const auto total = static_cast<Eigen::Index>(which.size());
  ssr_out.resize(total);
  const Eigen::Index blocks = (total + kBlock - 1) / kBlock;
  parallel_(blocks, [&](Eigen::Index block_begin, Eigen::Index block_end) {
    const Eigen::Index begin = block_begin * kBlock, end = std::min(total, block_end * kBlock);
    site::TruckBatch batch;
    std::vector<ExtendedPass> passes;
    Eigen::ArrayXXd model_if;
    for (Eigen::Index first = begin; first < end; first += kChunk) {
      const Eigen::Index count = std::min(kChunk, end - first);
      model_if.resize(obs_.sensors, count);
      if (extension_ != nullptr) {
        // Every pass shares one ψ, so the extended forward model builds an added profile once.
        passes.clear();
        for (Eigen::Index i = 0; i < count; ++i) {
          const int n = which[static_cast<std::size_t>(first + i)];
          passes.push_back({base_pass(site_, obs_.speed_mps[n], obs_.sprung_mass_kg[n], k[first + i], kt[first + i],
                                      z[first + i]),
                            psi});
        }
        simulate_passes(site_, extension_, passes, model_if);
      } else {
        batch.resize(count);
        for (Eigen::Index i = 0; i < count; ++i) {
          const int n = which[static_cast<std::size_t>(first + i)];
          batch.speed_mps[i] = obs_.speed_mps[n];
          batch.sprung_mass_kg[i] = obs_.sprung_mass_kg[n];
          batch.stiffness_npm[i] = k[first + i];
          batch.tyre_stiffness_npm[i] = kt[first + i];
          batch.lateral_m[i] = z[first + i];
        }
        site_.impact_factors(batch, model_if);
      }
      for (Eigen::Index i = 0; i < count; ++i) {
        const int n = which[static_cast<std::size_t>(first + i)];
        const double s = (model_if.col(i) - obs_.impact_factor.col(n)).square().sum();
        ssr_out[first + i] = std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
      }
    }
  });
  calls_ += (total + kChunk - 1) / kChunk;
  passes_ += total;
}

}  // namespace ssrfleet::fleet::detail
