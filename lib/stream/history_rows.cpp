#include "stream/history_rows.hpp"

#include <chrono>

#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"

namespace ssrfleet::stream {

records::HistoryReport history_rows(const fleet::PosteriorCloud& cloud, const site::Site& site,
                                    const predict::PredictionOptions& options, const HistoryRowsInput& input) {
  records::HistoryReport r;
  r.seq = input.seq;
  r.trucks = cloud.trucks_seen;
  r.time_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  r.source = input.source;
  r.lines_consumed = input.lines_consumed;
  r.ess = input.ess;
  r.checkpoint_checksum = input.checkpoint_checksum;
  const auto theta = fleet::summarise_cloud(cloud);
  for (std::size_t k = 0; k < theta.size(); ++k) {
    const auto& s = theta[k];
    r.hyperparameters.push_back({std::string(fleet::kHyperNames[k]), s.mean, s.sd, s.q025, s.q975});
  }
  const auto psi = fleet::summarise_psi(cloud);
  for (std::size_t k = 0; k < psi.size(); ++k) {
    const auto& s = psi[k];
    r.hyperparameters.push_back({cloud.psi_names[k], s.mean, s.sd, s.q025, s.q975});
  }
  predict::PredictionOptions seeded = options;
  seeded.seed = options.seed + input.seq;
  const auto p = predict::predict_ssr(cloud, site, {}, seeded);
  for (std::size_t i = 0; i < p.position_m.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    r.predictions.push_back({p.position_m[i], p.mean_if(j), p.lower95(j), p.upper95(j), p.mean_lower95(j),
                             p.mean_upper95(j)});
  }
  return r;
}

}  // namespace ssrfleet::stream
