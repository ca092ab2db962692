#include "stream/history_rows.hpp"

#include <algorithm>
#include <chrono>
#include <limits>

#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"
#include "predict/ssr_prediction.hpp"
#include "smc/weights.hpp"

namespace ssrfleet::stream {

records::HistoryReport history_rows(const fleet::ClassPosteriors& classes, const site::Site& site,
                                    const predict::PredictionOptions& options, const HistoryRowsInput& input,
                                    const fleet::ClassPosteriors* at_site) {
  records::HistoryReport r;
  r.seq = input.seq;
  r.time_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  r.source = input.source;
  r.lines_consumed = input.lines_consumed;
  r.checkpoint_checksum = input.checkpoint_checksum;
  r.ess = std::numeric_limits<double>::infinity();
  for (const auto& c : classes) {
    r.trucks += c.cloud.trucks_seen;
    r.ess = std::min(r.ess, smc::effective_sample_size(c.cloud.weights));
    const auto theta = fleet::summarise_cloud(c.cloud);
    for (std::size_t k = 0; k < theta.size(); ++k) {
      const auto& s = theta[k];
      r.hyperparameters.push_back({c.label, std::string(fleet::kHyperNames[k]), s.mean, s.sd, s.q025, s.q975});
    }
    const auto psi = fleet::summarise_psi(c.cloud);
    for (std::size_t k = 0; k < psi.size(); ++k) {
      const auto& s = psi[k];
      r.hyperparameters.push_back({c.label, c.cloud.psi_names[k], s.mean, s.sd, s.q025, s.q975});
    }
  }
  if (classes.empty()) r.ess = 0.0;
  predict::PredictionOptions seeded = options;
  seeded.seed = options.seed + input.seq;
  const fleet::ClassPosteriors& predicted = at_site != nullptr ? *at_site : classes;
  const auto p = predict::predict_ssr_mixture(predicted, fleet::observed_shares(predicted), site, {}, seeded);
  for (std::size_t i = 0; i < p.position_m.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    r.predictions.push_back({p.position_m[i], p.mean_if(j), p.lower95(j), p.upper95(j), p.mean_lower95(j),
                             p.mean_upper95(j)});
  }
  return r;
}

}  // namespace ssrfleet::stream
