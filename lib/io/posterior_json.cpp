#include "io/posterior_json.hpp"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "io/atomic_file.hpp"
#include "model/fleet_model.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
constexpr int kFormatVersion = 1;

// JSON has no NaN: a quantity that does not apply (MCMC log-evidence) is written as null.
nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }
}  // namespace

nlohmann::json posterior_to_json(const fleet::PosteriorCloud& c, const std::vector<fleet::ParameterSummary>& hyper,
                                 const std::vector<fleet::ParameterSummary>& psi) {
  if (hyper.size() != static_cast<std::size_t>(fleet::kHyperCount)) {
    throw std::invalid_argument("io::posterior_to_json(): " + std::to_string(hyper.size()) + " summaries for " +
                                std::to_string(fleet::kHyperCount) + " hyperparameters");
  }
  if (psi.size() != static_cast<std::size_t>(c.psi.rows()) || c.psi_names.size() != psi.size()) {
    throw std::invalid_argument("io::posterior_to_json(): " + std::to_string(psi.size()) + " summaries and " +
                                std::to_string(c.psi_names.size()) + " names for " + std::to_string(c.psi.rows()) +
                                " extension parameters");
  }
  nlohmann::json j;
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto& s = hyper[static_cast<std::size_t>(h)];
    j[std::string(fleet::kHyperNames[static_cast<std::size_t>(h)])] = {
        {"mean", s.mean}, {"sd", s.sd}, {"q025", s.q025}, {"q975", s.q975}};
  }
  j["trucks_seen"] = c.trucks_seen;
  j["particles"] = c.theta.cols();
  j["ess"] = c.ess;
  j["log_evidence"] = number_or_null(c.log_evidence);
  j["method"] = c.method;
  j["model"] = c.model;
  if (!psi.empty()) {
    nlohmann::json e = nlohmann::json::object();
    for (std::size_t k = 0; k < psi.size(); ++k) {
      e[c.psi_names[k]] = {{"mean", psi[k].mean}, {"sd", psi[k].sd}, {"q025", psi[k].q025}, {"q975", psi[k].q975}};
    }
    j["extension"] = std::move(e);
  }
  j["format_version"] = kFormatVersion;
  j["site"] = {{"fingerprint", c.site_fingerprint}, {"road", c.road_name}, {"sensors", c.sensors},
               {"lateral_min_m", c.lateral_min_m}, {"lateral_max_m", c.lateral_max_m}};
  nlohmann::json theta = nlohmann::json::array();
  for (Eigen::Index i = 0; i < c.theta.cols(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int h = 0; h < fleet::kHyperCount; ++h) row.push_back(c.theta(h, i));
    theta.push_back(std::move(row));
  }
  j["cloud"] = {{"weights", std::vector<double>(c.weights.data(), c.weights.data() + c.weights.size())},
                {"theta", std::move(theta)},
                {"speed_mps", c.speed_mps},
                {"sprung_mass_kg", c.sprung_mass_kg}};
  if (c.psi.rows() > 0) {
    nlohmann::json rows = nlohmann::json::array();
    for (Eigen::Index i = 0; i < c.psi.cols(); ++i) {
      nlohmann::json row = nlohmann::json::array();
      for (Eigen::Index k = 0; k < c.psi.rows(); ++k) row.push_back(c.psi(k, i));
      rows.push_back(std::move(row));
    }
    j["cloud"]["psi"] = std::move(rows);
    j["cloud"]["psi_names"] = c.psi_names;  // the rows' order (JSON objects have none)
  }
  return j;
}

void write_posterior_file(const std::string& path, const fleet::PosteriorCloud& cloud,
                          const std::vector<fleet::ParameterSummary>& hyper,
                          const std::vector<fleet::ParameterSummary>& psi) {
  const nlohmann::json j = posterior_to_json(cloud, hyper, psi);
  write_file_atomically(path, [&](std::ostream& os) { os << j.dump(1) << "\n"; });
}

namespace {
template <class T>
T get_field(const nlohmann::json& j, const char* key, const std::string& file, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw DataError(file, 0, where + key, "missing");
  const nlohmann::json& v = j.at(key);
  if constexpr (std::is_integral_v<T>) {
    // nlohmann converts any number to an integer by a plain cast, undefined behaviour for 1e300
    // (UBSan, found by fuzz/posterior_json_fuzzer): take whole numbers in T's range only.
    const bool fits = v.is_number_unsigned()
                          ? v.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max())
                          : v.is_number_integer() && v.get<std::int64_t>() >= std::numeric_limits<T>::min() &&
                                v.get<std::int64_t>() <= std::numeric_limits<T>::max();
    if (!fits) {
      throw DataError(file, 0, where + key,
                      "must be a whole number from " + std::to_string(std::numeric_limits<T>::min()) + " to " +
                          std::to_string(std::numeric_limits<T>::max()) + ", found " + v.dump());
    }
    return v.is_number_unsigned() ? static_cast<T>(v.get<std::uint64_t>()) : static_cast<T>(v.get<std::int64_t>());
  } else {
    try {
      return v.get<T>();
    } catch (const nlohmann::json::exception&) {
      throw DataError(file, 0, where + key, "has the wrong type");
    }
  }
}

std::vector<double> finite_array(const nlohmann::json& j, const char* key, const std::string& file) {
  auto v = get_field<std::vector<double>>(j, key, file, "cloud.");
  for (double x : v) {
    if (!std::isfinite(x)) throw DataError(file, 0, std::string("cloud.") + key, "holds a non-finite number");
  }
  return v;
}
}  // namespace

fleet::PosteriorCloud read_posterior_file(const std::string& path_in) {
  std::string path = path_in;
  if (std::filesystem::is_directory(path)) path = (std::filesystem::path(path) / "posterior.json").string();
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open posterior file '" + path + "'");
  return read_posterior(in, path);
}

fleet::PosteriorCloud read_posterior(std::istream& in, const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    // parse_error, and out_of_range for a number past a double ("2e4000", found by
    // fuzz/posterior_json_fuzzer: it escaped as an internal error).
    throw DataError(path, 0, "json", std::string("not valid JSON (") + e.what() + ")");
  }
  fleet::PosteriorCloud c;
  if (get_field<int>(j, "format_version", path, "") != kFormatVersion) {
    throw DataError(path, 0, "format_version", "unsupported version (this ssrfleet reads " + std::to_string(kFormatVersion) + ")");
  }
  c.method = get_field<std::string>(j, "method", path, "");
  c.trucks_seen = get_field<long>(j, "trucks_seen", path, "");
  c.ess = get_field<double>(j, "ess", path, "");
  c.log_evidence = j.contains("log_evidence") && j["log_evidence"].is_number() ? j["log_evidence"].get<double>() : NAN;
  const auto& site = j.contains("site") ? j["site"] : nlohmann::json();
  c.site_fingerprint = get_field<std::string>(site, "fingerprint", path, "site.");
  c.road_name = get_field<std::string>(site, "road", path, "site.");
  c.sensors = get_field<int>(site, "sensors", path, "site.");
  c.lateral_min_m = get_field<double>(site, "lateral_min_m", path, "site.");
  c.lateral_max_m = get_field<double>(site, "lateral_max_m", path, "site.");
  const auto& cloud = j.contains("cloud") ? j["cloud"] : nlohmann::json();
  const auto weights = finite_array(cloud, "weights", path);
  c.speed_mps = finite_array(cloud, "speed_mps", path);
  c.sprung_mass_kg = finite_array(cloud, "sprung_mass_kg", path);
  const auto theta = get_field<std::vector<std::vector<double>>>(cloud, "theta", path, "cloud.");
  if (weights.empty() || theta.size() != weights.size()) {
    throw DataError(path, 0, "cloud.theta", "needs one row per weight (" + std::to_string(weights.size()) + ")");
  }
  if (c.speed_mps.empty() || c.speed_mps.size() != c.sprung_mass_kg.size()) {
    throw DataError(path, 0, "cloud.speed_mps", "needs one speed and one sprung mass per observed truck");
  }
  c.theta.resize(fleet::kHyperCount, static_cast<Eigen::Index>(theta.size()));
  c.weights.resize(static_cast<Eigen::Index>(weights.size()));
  double total = 0.0;
  for (std::size_t i = 0; i < theta.size(); ++i) {
    if (theta[i].size() != fleet::kHyperCount) {
      throw DataError(path, 0, "cloud.theta[" + std::to_string(i) + "]", "needs " + std::to_string(fleet::kHyperCount) + " values");
    }
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const double x = theta[i][static_cast<std::size_t>(h)];
      if (!std::isfinite(x)) throw DataError(path, 0, "cloud.theta[" + std::to_string(i) + "]", "holds a non-finite number");
      c.theta(h, static_cast<Eigen::Index>(i)) = x;
    }
    if (weights[i] < 0.0) throw DataError(path, 0, "cloud.weights", "holds a negative weight");
    c.weights[static_cast<Eigen::Index>(i)] = weights[i];
    total += weights[i];
  }
  if (!(total > 0.0)) throw DataError(path, 0, "cloud.weights", "all weights are zero");
  c.weights /= total;
  // The model: files written before models existed are the base model's.
  c.model = j.contains("model") ? get_field<std::string>(j, "model", path, "") : "base";
  if (c.model.empty()) throw DataError(path, 0, "model", "is empty (\"base\" or a model spec)");
  if (c.model != "base" && cloud.contains("psi")) {  // none when the spec fixes every parameter
    c.psi_names = get_field<std::vector<std::string>>(cloud, "psi_names", path, "cloud.");
    if (c.psi_names.empty()) throw DataError(path, 0, "cloud.psi_names", "empty for model '" + c.model + "'");
    const auto rows = get_field<std::vector<std::vector<double>>>(cloud, "psi", path, "cloud.");
    if (rows.size() != weights.size()) {
      throw DataError(path, 0, "cloud.psi", "needs one row per weight (" + std::to_string(weights.size()) + ")");
    }
    c.psi.resize(static_cast<Eigen::Index>(c.psi_names.size()), static_cast<Eigen::Index>(rows.size()));
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (rows[i].size() != c.psi_names.size()) {
        throw DataError(path, 0, "cloud.psi[" + std::to_string(i) + "]",
                        "needs " + std::to_string(c.psi_names.size()) + " values (one per extension parameter)");
      }
      for (std::size_t k = 0; k < rows[i].size(); ++k) {
        if (!std::isfinite(rows[i][k])) throw DataError(path, 0, "cloud.psi[" + std::to_string(i) + "]", "holds a non-finite number");
        c.psi(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(i)) = rows[i][k];
      }
    }
  }
  return c;
}

}  // namespace ssrfleet::io
