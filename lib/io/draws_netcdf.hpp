// The draws as NetCDF4 in ArviZ's InferenceData layout (docs/draws.md), so that
// arviz.from_netcdf(FILE) or xarray.open_dataset(FILE, group=...) read them. One netCDF4 group per
// InferenceData group, each with its own dimensions and coordinate variables:
//   posterior           each hyperparameter (fleet_model.hpp names) and each free model parameter
//                       (psi_names) as a double variable of dims (chain, draw), with its `units`;
//   sample_stats        `source_index` (chain, draw): the posterior file's cloud column a draw copies;
//                       `log_marginal_likelihood` (chain), SMC only; `weight_ess` (chain), SMC only;
//                       for several MCMC chains their diagnostics by `parameter`: `rhat`, `ess_bulk`,
//                       `ess_tail`, `mcse_mean`, `mcse_q05`, `mcse_q95`;
//   observed_data       `if` (truck, sensor), when the fitted log is given (sensor numbered 1..M,
//                       as the log's if_1..if_M; truck by the log's truck ids);
//   constant_data       `speed_mps`, `sprung_mass_kg` (truck), with the observed data;
//   posterior_predictive `if` (chain, draw, truck, sensor), when predictive draws are given
//                       (fleet/posterior_predictive_draws.hpp: a subset, its `draw` coordinate the
//                       posterior's draw numbers, its trucks the log's first ones).
// Every group carries ArviZ's attributes (`created_at`, `inference_library` = "ssrfleet",
// `inference_library_version`) and the fit's: `model_spec`, `method`, `road`, `site_fingerprint`,
// `trucks_seen`. netcdf.h stays inside io: the readers below are what tests and tools use to look in.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fleet/equal_weight_draws.hpp"
#include "fleet/posterior_cloud.hpp"
#include "fleet/posterior_predictive_draws.hpp"
#include "records/wim_record.hpp"

namespace ssrfleet::io {

struct DrawsFileInfo {
  std::string created_at;       // ISO 8601 UTC without a zone suffix, as ArviZ writes it
  std::string library_version;  // ssrfleet's
};
// Now, in DrawsFileInfo::created_at's form, to the microsecond ("2026-11-28T10:50:12.123456").
std::string iso_utc_now();

// The fitted log as observed_data and constant_data hold it.
struct ObservedLog {
  std::vector<std::string> truck_id;
  Eigen::MatrixXd impact_factor;  // trucks x sensors
  std::vector<double> speed_mps, sprung_mass_kg;
};
// std::invalid_argument when the records' sensor counts differ.
ObservedLog observed_log_of(const std::vector<records::WimRecord>& records);

// Writes `path` through a temporary sibling renamed over it (no partial file on any failure).
// observed, predictive: optional (null: the group is left out). IoError naming the path on a
// failure to write; std::invalid_argument when the pieces disagree in their sizes.
void write_draws_netcdf(const std::string& path, const fleet::PosteriorCloud& cloud,
                        const fleet::EqualWeightDraws& draws, const DrawsFileInfo& info,
                        const ObservedLog* observed = nullptr,
                        const fleet::PosteriorPredictiveDraws* predictive = nullptr);

// Reading back (tests, tools): the file's group names; a variable's dims, shape and values as
// doubles (integers converted); a text attribute. A missing file is MissingInputError; a missing
// group, variable or attribute, or a file that is not netCDF, a DataError naming the file and
// "group/name".
struct NetcdfVariable {
  std::vector<std::string> dims;
  std::vector<std::size_t> shape;
  std::vector<double> values;  // row-major
};
std::vector<std::string> netcdf_groups(const std::string& path);
NetcdfVariable read_netcdf_variable(const std::string& path, const std::string& group,
                                    const std::string& name);
std::vector<std::string> read_netcdf_strings(const std::string& path, const std::string& group,
                                             const std::string& name);
std::string read_netcdf_text_attribute(const std::string& path, const std::string& group,
                                       const std::string& name);

}  // namespace ssrfleet::io
