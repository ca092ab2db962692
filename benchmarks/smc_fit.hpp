// An offline fit with the marginal SMC core as `ssrfleet fit` does it: every record absorbed in
// order, then rejuvenate(final_sweeps) (MarginalSmc::Options), and the posterior summarised the
// way the posterior file reports it (fleet::summarise_cloud: weighted mean, sd, 2.5 / 97.5 %
// quantiles).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "fleet/marginal_smc.hpp"
#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"
#include "records/wim_record.hpp"

namespace ssrfleet::bench {

using HyperSummary = std::array<fleet::ParameterSummary, fleet::kHyperCount>;

// Default options with the engine's seed set (the SMC seed, not the data seed).
inline fleet::MarginalSmc::Options smc_options(std::uint64_t smc_seed, int threads) {
  fleet::MarginalSmc::Options o;
  o.sampler.seed = smc_seed;
  o.sampler.threads = threads;
  return o;
}

inline void replay_and_rejuvenate(fleet::MarginalSmc& smc, const std::vector<records::WimRecord>& records,
                                  int final_sweeps) {
  for (std::size_t t = 0; t < records.size(); ++t) {
    smc.prepare(records, t);  // the next trucks' tables built one per thread, as fleet::replay does
    smc.absorb(records[t]);
  }
  smc.rejuvenate(final_sweeps);
}

inline HyperSummary summarise_hypers(const fleet::PosteriorCloud& cloud) {
  const std::vector<fleet::ParameterSummary> rows = fleet::summarise_cloud(cloud);
  HyperSummary s{};
  for (int h = 0; h < fleet::kHyperCount; ++h) s[static_cast<std::size_t>(h)] = rows.at(static_cast<std::size_t>(h));
  return s;
}

}  // namespace ssrfleet::bench
