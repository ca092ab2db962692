#include "io/draws_netcdf.hpp"

#include <netcdf.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <stdexcept>

#include "io/write_faults.hpp"
#include "model/fleet_model.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {

// The units of the hyperparameters, fleet_model.hpp order (docs/model.md).
constexpr std::array<const char*, fleet::kHyperCount> kHyperUnits = {"N/m", "N/m", "N/m", "N/m",
                                                                     "m",   "m",   "1"};

// One open file, closed on every path out (a failed write must not leave a handle on the
// temporary that is about to be removed).
class NcFile {
 public:
  NcFile(const std::string& path, const std::string& shown) : shown_(shown) {
    check(nc_create(path.c_str(), NC_NETCDF4 | NC_CLOBBER, &id_), "create");
    open_ = true;
  }
  ~NcFile() {
    if (open_) nc_close(id_);
  }
  NcFile(const NcFile&) = delete;
  NcFile& operator=(const NcFile&) = delete;
  void close() {
    open_ = false;
    check(nc_close(id_), "close");
  }
  int id() const { return id_; }
  void check(int status, const std::string& what) const {
    if (status != NC_NOERR)
      throw IoError("writing '" + shown_ + "' failed (" + what + "): " + nc_strerror(status));
  }

 private:
  std::string shown_;
  int id_ = -1;
  bool open_ = false;
};

// One InferenceData group being written: its dimensions, variables and attributes.
class Group {
 public:
  Group(const NcFile& file, const std::string& name) : file_(file) {
    file_.check(nc_def_grp(file.id(), name.c_str(), &id_), "group " + name);
    name_ = name;
  }
  // A dimension with its integer coordinate variable 0..n-1 (what ArviZ gives chain and draw).
  int index_dim(const std::string& name, std::size_t n) {
    std::vector<long long> values(n);
    for (std::size_t i = 0; i < n; ++i) values[i] = static_cast<long long>(i);
    return numbered_dim(name, values);
  }
  // A dimension whose integer coordinate holds `values` (a subset's own numbers).
  int numbered_dim(const std::string& name, const std::vector<long long>& values) {
    const int dim = def_dim(name, values.size());
    const int var = def_var(name, NC_INT64, {dim});
    if (!values.empty()) file_.check(nc_put_var_longlong(id_, var, values.data()), name_ + "/" + name);
    return dim;
  }
  // A dimension whose coordinate is text (truck ids, parameter names), as xarray writes a string
  // array encoded as characters: NC_CHAR over (name, stringN), N the longest label, with
  // `_Encoding` utf-8, which xarray decodes back to strings. Variable-length strings (NC_STRING)
  // would do too, but libnetcdf 4.9.0 with HDF5 1.10 then fails to reopen the file ("HDF error")
  // after another handle on it is closed, which xarray and ArviZ do.
  int string_dim(const std::string& name, const std::vector<std::string>& labels) {
    std::size_t longest = 1;
    for (const auto& s : labels) longest = std::max(longest, s.size());
    const int dim = def_dim(name, labels.size());
    const std::string chars_name = "string" + std::to_string(longest);
    int chars = -1;
    if (nc_inq_dimid(id_, chars_name.c_str(), &chars) != NC_NOERR) chars = def_dim(chars_name, longest);
    const int var = def_var(name, NC_CHAR, {dim, chars});
    text_attribute(var, "_Encoding", "utf-8");
    std::string block(labels.size() * longest, '\0');
    for (std::size_t i = 0; i < labels.size(); ++i) block.replace(i * longest, labels[i].size(), labels[i]);
    if (!labels.empty()) file_.check(nc_put_var_text(id_, var, block.data()), name_ + "/" + name);
    return dim;
  }
  void doubles(const std::string& name, const std::vector<int>& dims, const double* values,
               const char* units) {
    const int var = def_var(name, NC_DOUBLE, dims);
    if (units != nullptr) text_attribute(var, "units", units);
    file_.check(nc_put_var_double(id_, var, values), name_ + "/" + name);
  }
  void int64s(const std::string& name, const std::vector<int>& dims, const std::vector<long long>& values) {
    const int var = def_var(name, NC_INT64, dims);
    file_.check(nc_put_var_longlong(id_, var, values.data()), name_ + "/" + name);
  }
  void text_attribute(int var, const std::string& name, const std::string& value) {
    file_.check(nc_put_att_text(id_, var, name.c_str(), value.size(), value.c_str()),
                name_ + " attribute " + name);
  }
  void integer_attribute(const std::string& name, long long value) {
    file_.check(nc_put_att_longlong(id_, NC_GLOBAL, name.c_str(), NC_INT64, 1, &value),
                name_ + " attribute " + name);
  }

 private:
  int def_dim(const std::string& name, std::size_t n) {
    int dim = -1;
    file_.check(nc_def_dim(id_, name.c_str(), n, &dim), name_ + " dimension " + name);
    return dim;
  }
  int def_var(const std::string& name, nc_type type, const std::vector<int>& dims) {
    int var = -1;
    file_.check(nc_def_var(id_, name.c_str(), type, static_cast<int>(dims.size()), dims.data(), &var),
                name_ + "/" + name);
    return var;
  }

  const NcFile& file_;
  std::string name_;
  int id_ = -1;
};

void common_attributes(Group& g, const fleet::PosteriorCloud& cloud, const DrawsFileInfo& info) {
  g.text_attribute(NC_GLOBAL, "created_at", info.created_at);
  g.text_attribute(NC_GLOBAL, "inference_library", "ssrfleet");
  g.text_attribute(NC_GLOBAL, "inference_library_version", info.library_version);
  g.text_attribute(NC_GLOBAL, "model_spec", cloud.model);
  g.text_attribute(NC_GLOBAL, "method", cloud.method);
  g.text_attribute(NC_GLOBAL, "road", cloud.road_name);
  g.text_attribute(NC_GLOBAL, "site_fingerprint", cloud.site_fingerprint);
  g.integer_attribute("trucks_seen", cloud.trucks_seen);
}

// Column-major Eigen rows (one parameter over chain-major draws) are already (chain, draw) row-major.
std::vector<double> row_of(const Eigen::MatrixXd& m, Eigen::Index r) {
  std::vector<double> v(static_cast<std::size_t>(m.cols()));
  for (Eigen::Index i = 0; i < m.cols(); ++i) v[static_cast<std::size_t>(i)] = m(r, i);
  return v;
}

void write_posterior(const NcFile& file, const fleet::PosteriorCloud& cloud,
                     const fleet::EqualWeightDraws& draws, const DrawsFileInfo& info) {
  Group g(file, "posterior");
  common_attributes(g, cloud, info);
  const std::vector<int> dims = {g.index_dim("chain", static_cast<std::size_t>(draws.chains)),
                                 g.index_dim("draw", static_cast<std::size_t>(draws.draws))};
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    g.doubles(std::string(fleet::kHyperNames[static_cast<std::size_t>(h)]), dims,
              row_of(draws.theta, h).data(), kHyperUnits[static_cast<std::size_t>(h)]);
  }
  for (Eigen::Index k = 0; k < draws.psi.rows(); ++k) {
    g.doubles(cloud.psi_names[static_cast<std::size_t>(k)], dims, row_of(draws.psi, k).data(), nullptr);
  }
}

void write_sample_stats(const NcFile& file, const fleet::PosteriorCloud& cloud,
                        const fleet::EqualWeightDraws& draws, const DrawsFileInfo& info) {
  Group g(file, "sample_stats");
  common_attributes(g, cloud, info);
  if (cloud.pooled_sweeps > 0) g.integer_attribute("pooled_sweeps", cloud.pooled_sweeps);
  const int chain = g.index_dim("chain", static_cast<std::size_t>(draws.chains));
  const int draw = g.index_dim("draw", static_cast<std::size_t>(draws.draws));
  std::vector<long long> source(draws.source.begin(), draws.source.end());
  g.int64s("source_index", {chain, draw}, source);
  if (cloud.method == "smc") {
    // One run: its own values, by chain. Several runs (fit --runs): the pooled posterior's (the log
    // of the runs' mean evidence, the ESS of all their weights), as scalars.
    const std::vector<int> by_chain = draws.chains == 1 ? std::vector<int>{chain} : std::vector<int>{};
    g.doubles("log_marginal_likelihood", by_chain, &cloud.log_evidence, nullptr);
    g.doubles("weight_ess", by_chain, &cloud.weight_ess, nullptr);
  }
  if (!cloud.convergence.empty()) {
    std::vector<std::string> names;
    for (const auto& p : cloud.convergence) names.push_back(p.name);
    const int parameter = g.string_dim("parameter", names);
    const auto column = [&](double fleet::ParameterConvergence::*field) {
      std::vector<double> v;
      for (const auto& p : cloud.convergence) v.push_back(p.*field);
      return v;
    };
    g.doubles("rhat", {parameter}, column(&fleet::ParameterConvergence::rhat).data(), nullptr);
    g.doubles("ess_bulk", {parameter}, column(&fleet::ParameterConvergence::ess_bulk).data(), nullptr);
    g.doubles("ess_tail", {parameter}, column(&fleet::ParameterConvergence::ess_tail).data(), nullptr);
    g.doubles("mcse_mean", {parameter}, column(&fleet::ParameterConvergence::mcse_mean).data(), nullptr);
    g.doubles("mcse_q05", {parameter}, column(&fleet::ParameterConvergence::mcse_q05).data(), nullptr);
    g.doubles("mcse_q95", {parameter}, column(&fleet::ParameterConvergence::mcse_q95).data(), nullptr);
    if (cloud.method == "smc") {
      g.doubles("ess_equivalent", {parameter}, column(&fleet::ParameterConvergence::ess_equivalent).data(), nullptr);
    }
  }
}

// Sensors numbered as the log's columns if_1..if_M.
std::vector<long long> sensor_numbers(Eigen::Index sensors) {
  std::vector<long long> numbers;
  for (Eigen::Index s = 1; s <= sensors; ++s) numbers.push_back(s);
  return numbers;
}

void write_observed(const NcFile& file, const fleet::PosteriorCloud& cloud, const ObservedLog& log,
                    const DrawsFileInfo& info) {
  const std::size_t trucks = log.truck_id.size();
  std::vector<double> values(trucks * static_cast<std::size_t>(log.impact_factor.cols()));
  for (std::size_t t = 0; t < trucks; ++t) {
    for (Eigen::Index s = 0; s < log.impact_factor.cols(); ++s) {
      values[t * static_cast<std::size_t>(log.impact_factor.cols()) + static_cast<std::size_t>(s)] =
          log.impact_factor(static_cast<Eigen::Index>(t), s);
    }
  }
  {
    Group g(file, "observed_data");
    common_attributes(g, cloud, info);
    const std::vector<int> dims = {g.string_dim("truck", log.truck_id),
                                   g.numbered_dim("sensor", sensor_numbers(log.impact_factor.cols()))};
    g.doubles("if", dims, values.data(), "1");
  }
  Group g(file, "constant_data");
  common_attributes(g, cloud, info);
  const int truck = g.string_dim("truck", log.truck_id);
  g.doubles("speed_mps", {truck}, log.speed_mps.data(), "m/s");
  g.doubles("sprung_mass_kg", {truck}, log.sprung_mass_kg.data(), "kg");
}

void write_predictive(const NcFile& file, const fleet::PosteriorCloud& cloud,
                      const fleet::EqualWeightDraws& draws, const ObservedLog& log,
                      const fleet::PosteriorPredictiveDraws& p, const DrawsFileInfo& info) {
  Group g(file, "posterior_predictive");
  common_attributes(g, cloud, info);
  const std::vector<std::string> ids(log.truck_id.begin(), log.truck_id.begin() + p.trucks);
  const std::vector<long long> draw_numbers(p.draw_index.begin(), p.draw_index.end());
  const std::vector<int> dims = {g.index_dim("chain", static_cast<std::size_t>(draws.chains)),
                                 g.numbered_dim("draw", draw_numbers), g.string_dim("truck", ids),
                                 g.numbered_dim("sensor", sensor_numbers(p.impact_factor.cols()))};
  std::vector<double> values(static_cast<std::size_t>(p.impact_factor.size()));
  std::size_t i = 0;
  for (Eigen::Index r = 0; r < p.impact_factor.rows(); ++r) {
    for (Eigen::Index s = 0; s < p.impact_factor.cols(); ++s) values[i++] = p.impact_factor(r, s);
  }
  g.doubles("if", dims, values.data(), "1");
}

void check_sizes(const fleet::PosteriorCloud& cloud, const fleet::EqualWeightDraws& draws,
                 const ObservedLog* observed, const fleet::PosteriorPredictiveDraws* predictive) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("io::write_draws_netcdf(): " + what);
  };
  if (draws.theta.rows() != fleet::kHyperCount || draws.theta.cols() != draws.chains * draws.draws ||
      static_cast<Eigen::Index>(draws.source.size()) != draws.theta.cols()) {
    fail("draws do not match chains x draws");
  }
  if (static_cast<Eigen::Index>(cloud.psi_names.size()) != draws.psi.rows())
    fail("psi names do not match the draws");
  if (observed != nullptr) {
    const auto n = static_cast<Eigen::Index>(observed->truck_id.size());
    if (observed->impact_factor.rows() != n || static_cast<Eigen::Index>(observed->speed_mps.size()) != n ||
        static_cast<Eigen::Index>(observed->sprung_mass_kg.size()) != n) {
      fail("observed log's columns differ in length");
    }
  }
  if (predictive != nullptr) {
    if (observed == nullptr) fail("posterior predictive without the observed log");
    const auto n = static_cast<Eigen::Index>(predictive->draw_index.size());
    if (n > draws.draws || predictive->trucks > observed->impact_factor.rows() ||
        predictive->impact_factor.rows() != draws.chains * n * predictive->trucks ||
        predictive->impact_factor.cols() != observed->impact_factor.cols()) {
      fail("posterior predictive's shape does not match the draws and the log");
    }
  }
}

}  // namespace

std::string iso_utc_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto micro =
      std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch()).count() % 1000000;
  std::tm utc{};
  gmtime_r(&t, &utc);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%04d-%02d-%02dT%02d:%02d:%02d.%06lld", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                static_cast<long long>(micro));
  return buffer;
}

ObservedLog observed_log_of(const std::vector<records::WimRecord>& records) {
  ObservedLog log;
  const Eigen::Index sensors = records.empty() ? 0 : records.front().impact_factor.size();
  log.impact_factor.resize(static_cast<Eigen::Index>(records.size()), sensors);
  for (std::size_t t = 0; t < records.size(); ++t) {
    const auto& r = records[t];
    if (r.impact_factor.size() != sensors) {
      throw std::invalid_argument("io::observed_log_of(): records of " + std::to_string(sensors) + " and " +
                                  std::to_string(r.impact_factor.size()) + " sensors");
    }
    log.truck_id.push_back(r.truck_id);
    log.impact_factor.row(static_cast<Eigen::Index>(t)) = r.impact_factor.transpose();
    log.speed_mps.push_back(r.speed_mps);
    log.sprung_mass_kg.push_back(r.sprung_mass_kg);
  }
  return log;
}

void write_draws_netcdf(const std::string& path, const fleet::PosteriorCloud& cloud,
                        const fleet::EqualWeightDraws& draws, const DrawsFileInfo& info,
                        const ObservedLog* observed, const fleet::PosteriorPredictiveDraws* predictive) {
  check_sizes(cloud, draws, observed, predictive);
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  try {
    NcFile file(tmp, path);
    write_posterior(file, cloud, draws, info);
    write_sample_stats(file, cloud, draws, info);
    if (observed != nullptr) write_observed(file, cloud, *observed, info);
    if (predictive != nullptr) write_predictive(file, cloud, draws, *observed, *predictive, info);
    file.close();
    check_write_fault(
        path);  // a test's full disk strikes here: the temporary exists, the target is untouched
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      throw IoError("cannot rename '" + tmp + "' to '" + path + "'");
    }
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
}

}  // namespace ssrfleet::io
