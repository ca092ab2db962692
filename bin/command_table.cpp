#include "command_table.hpp"

#include <algorithm>

#include "commands.hpp"

namespace ssrfleet::cli {

const std::vector<CommandInfo>& command_table() {
  static const std::vector<CommandInfo> table = [] {
    std::vector<CommandInfo> t = {
        {"simulate", run_simulate,
         "simulate a fleet over a road and write a WIM log (impact factors or raw tyre forces)"},
        {"road", run_road,
         "describe a road (a preset, road CSV, OpenCRG or ERD file) or convert it to another format"},
        {"fit", run_fit, "fit the fleet posterior to a WIM log (SMC, or the batch MCMC)"},
        {"stream", run_stream, "update the posterior truck by truck from a live WIM stream (crash-safe)"},
        {"predict", run_predict, "predict the SSR pattern from a posterior, on this road or another"},
        {"diagnose", run_diagnose,
         "find, name and fit the effect the model misses (checks, extensions, Bayes factors)"},
        {"effects", run_effects,
         "list the effect catalogue: what each effect models, its parameters with units and ranges, and "
         "how to write a model spec"},
        {"damage", run_damage,
         "damage along the road: fourth-power amplification, DLC, hot spots, ESAL per million trucks"},
        {"weigh", run_weigh, "SSR-corrected static wheel loads from a log of raw tyre forces"},
        {"draws", run_draws,
         "write a posterior's equal-weight draws as CSV or NetCDF4 in ArviZ's layout, for numpy, pandas, xarray"},
        {"serve", run_serve,
         "a live web page and JSON API over running streams: SSR, hyperparameters, rejects, damage (read-only)"},
        {"sites", run_sites,
         "check a site manifest, list its sites, collect their posteriors into one table"},
        {"reproduce", run_reproduce,
         "the paper's theoretical test end to end: figure data, plots, summary.md"},
    };
    std::sort(t.begin(), t.end(), [](const CommandInfo& a, const CommandInfo& b) { return a.name < b.name; });
    return t;
  }();
  return table;
}

const CommandInfo* find_command(const std::string& name) {
  for (const auto& c : command_table()) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

}  // namespace ssrfleet::cli
