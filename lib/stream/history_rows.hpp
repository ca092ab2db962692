// What the stream's history (io/history_db.hpp) stores at a checkpoint: each class's posterior
// summaries and a light SSR prediction of the classes' mixture at their observed shares (the one
// posterior itself without classes), computed from the clouds the checkpoint holds. A pure function of the
// cloud, the seq and the options, so a resume that must write a missing row set writes exactly the
// rows the interrupted run would have (only time_s differs).
#pragma once

#include <cstdint>
#include <string>

#include "fleet/vehicle_classes.hpp"
#include "predict/ssr_prediction.hpp"
#include "records/history_report.hpp"
#include "site/site.hpp"

namespace ssrfleet::stream {

struct HistoryRowsInput {
  std::uint64_t seq = 0;
  std::string source;
  std::uint64_t lines_consumed = 0;
  std::uint64_t checkpoint_checksum = 0;
};

// The prediction's seed is options.seed + seq: every checkpoint's prediction is reproducible.
// The trucks and hyperparameter summaries come from `classes`; the prediction at `site` from
// `at_site` when given (a stream of several sites: the classes seen from that site, fleet::cloud_at_site).
records::HistoryReport history_rows(const fleet::ClassPosteriors& classes, const site::Site& site,
                                    const predict::PredictionOptions& options, const HistoryRowsInput& input,
                                    const fleet::ClassPosteriors* at_site = nullptr);

}  // namespace ssrfleet::stream
