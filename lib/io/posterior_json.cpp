#include "io/posterior_json.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <unordered_set>
#include <utility>

#include "io/atomic_file.hpp"
#include "io/json_fields.hpp"
#include "io/posterior_convergence_json.hpp"
#include "io/posterior_json_sites.hpp"
#include "model/fleet_model.hpp"
#include "records/vehicle_class.hpp"
#include "site/sensor_array.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
constexpr int kFormatVersion = 1;
constexpr int kClassesFormatVersion = 2;  // a file of vehicle classes

// JSON has no NaN: a quantity that does not apply (MCMC log-evidence) is written as null.
nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

// The file's own checksum: FNV-1a 64 of the compact dump of everything but
// "checksum". The dump is canonical (object keys sorted, each double in its shortest round-trip
// form), so a parsed file dumps to the very text its writer hashed; a changed value changes it,
// while re-indenting the file does not.
constexpr const char* kChecksumKey = "checksum";
constexpr const char* kChecksumPrefix = "fnv1a64:";

// The checksum of `j`, which must hold no "checksum" member (no copy of the tree is made: a
// stream writes a posterior file after every truck).
std::string content_checksum(const nlohmann::json& j) {
  const std::string text = j.dump();
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                static_cast<unsigned long long>(detail::fnv1a(detail::kFnvOffset, text.data(), text.size())));
  return kChecksumPrefix + std::string(hex);
}

}  // namespace

std::string posterior_file_text(nlohmann::json j) {
  j.erase(kChecksumKey);
  j[kChecksumKey] = content_checksum(j);
  return j.dump(1) + "\n";
}

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
  // Two different numbers, each under its own name (files before them held one of them as "ess").
  if (c.method == "mcmc") {
    j["min_ess"] = number_or_null(c.min_ess);  // null: no hyperparameter varied
  } else {
    j["weight_ess"] = c.weight_ess;
  }
  if (c.pooled_sweeps > 0) j["pooled_sweeps"] = c.pooled_sweeps;  // "particles" then counts every sweep's copy
  write_convergence(c, j);
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
  if (!c.sites.empty()) {
    // A fit of several sites: each site as "site" would hold it, its trucks and its part of the pool.
    nlohmann::json sites = nlohmann::json::array();
    for (const auto& s : c.sites) {
      sites.push_back({{"name", s.name}, {"fingerprint", s.fingerprint}, {"road", s.road_name}, {"sensors", s.sensors},
                       {"lateral_min_m", s.lateral_min_m}, {"lateral_max_m", s.lateral_max_m},
                       {"trucks_seen", s.trucks_seen}, {"pool", {s.pool_begin, s.pool_count}}});
    }
    j["site"]["sites"] = std::move(sites);
  }
  if (!c.calibration.empty()) {
    nlohmann::json calibration = nlohmann::json::array();
    for (const auto& s : c.calibration) {
      nlohmann::json e = {{"site", s.site}, {"gain", s.gain}};
      if (!s.se.empty()) e["se"] = s.se;
      calibration.push_back(std::move(e));
    }
    j["calibration"] = std::move(calibration);
  }
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
  const std::string text = posterior_file_text(posterior_to_json(cloud, hyper, psi));
  write_file_atomically(path, [&](std::ostream& os) { os << text; });
}

using json_fields::finite_array;
using json_fields::finite_numbers;
using json_fields::get_field;

namespace {

// One posterior object (the whole single-class file, or one entry of "classes"); P prefixes the
// fields' names in messages ("" or "classes[i].").
fleet::PosteriorCloud parse_posterior_object(const nlohmann::json& j, const std::string& path, const std::string& P) {
  fleet::PosteriorCloud c;
  if (get_field<int>(j, "format_version", path, P) != kFormatVersion) {
    throw DataError(path, 0, P + "format_version", "unsupported version (this ssrfleet reads " + std::to_string(kFormatVersion) + ")");
  }
  c.method = get_field<std::string>(j, "method", path, P);
  c.trucks_seen = get_field<long>(j, "trucks_seen", path, P);
  // Files written before the two names held the method's number as "ess".
  const char* ess_name = c.method == "mcmc" ? "min_ess" : "weight_ess";
  const char* ess_field = j.contains(ess_name) || !j.contains("ess") ? ess_name : "ess";
  const double ess = j.contains(ess_field) && j[ess_field].is_null() ? NAN : get_field<double>(j, ess_field, path, P);
  if (c.method == "mcmc") {
    c.min_ess = ess;
  } else {
    c.weight_ess = ess;
  }
  c.pooled_sweeps = j.contains("pooled_sweeps") ? get_field<int>(j, "pooled_sweeps", path, P) : 0;
  if (c.pooled_sweeps < 0) throw DataError(path, 0, P + "pooled_sweeps", "must be >= 0");
  read_convergence(j, path, P, c);
  c.log_evidence = j.contains("log_evidence") && j["log_evidence"].is_number() ? j["log_evidence"].get<double>() : NAN;
  const auto& site = j.contains("site") ? j["site"] : nlohmann::json();
  c.site_fingerprint = get_field<std::string>(site, "fingerprint", path, P + "site.");
  c.road_name = get_field<std::string>(site, "road", path, P + "site.");
  c.sensors = get_field<int>(site, "sensors", path, P + "site.");
  c.lateral_min_m = get_field<double>(site, "lateral_min_m", path, P + "site.");
  c.lateral_max_m = get_field<double>(site, "lateral_max_m", path, P + "site.");
  const auto& cloud = j.contains("cloud") ? j["cloud"] : nlohmann::json();
  const auto weights = finite_array(cloud, "weights", path, P);
  c.speed_mps = finite_array(cloud, "speed_mps", path, P);
  c.sprung_mass_kg = finite_array(cloud, "sprung_mass_kg", path, P);
  const auto theta = get_field<std::vector<std::vector<double>>>(cloud, "theta", path, P + "cloud.");
  if (weights.empty() || theta.size() != weights.size()) {
    throw DataError(path, 0, P + "cloud.theta", "needs one row per weight (" + std::to_string(weights.size()) + ")");
  }
  if (c.speed_mps.empty() || c.speed_mps.size() != c.sprung_mass_kg.size()) {
    throw DataError(path, 0, P + "cloud.speed_mps", "needs one speed and one sprung mass per observed truck");
  }
  c.theta.resize(fleet::kHyperCount, static_cast<Eigen::Index>(theta.size()));
  c.weights.resize(static_cast<Eigen::Index>(weights.size()));
  double total = 0.0;
  for (std::size_t i = 0; i < theta.size(); ++i) {
    if (theta[i].size() != fleet::kHyperCount) {
      throw DataError(path, 0, P + "cloud.theta[" + std::to_string(i) + "]", "needs " + std::to_string(fleet::kHyperCount) + " values");
    }
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const double x = theta[i][static_cast<std::size_t>(h)];
      if (!std::isfinite(x)) throw DataError(path, 0, P + "cloud.theta[" + std::to_string(i) + "]", "holds a non-finite number");
      c.theta(h, static_cast<Eigen::Index>(i)) = x;
    }
    if (weights[i] < 0.0) throw DataError(path, 0, P + "cloud.weights", "holds a negative weight");
    c.weights[static_cast<Eigen::Index>(i)] = weights[i];
    total += weights[i];
  }
  if (!(total > 0.0)) throw DataError(path, 0, P + "cloud.weights", "all weights are zero");
  c.weights /= total;
  if (c.method == "mcmc") c.weight_ess = static_cast<double>(c.weights.size());  // equal weights
  // The model: files written before models existed are the base model's.
  if (site.contains("sites")) parse_posterior_sites(site["sites"], path, P + "site.sites", c);
  if (j.contains("calibration")) parse_posterior_calibration(j["calibration"], path, P + "calibration", c);
  c.model = j.contains("model") ? get_field<std::string>(j, "model", path, P) : "base";
  if (c.model.empty()) throw DataError(path, 0, P + "model", "is empty (\"base\" or a model spec)");
  if (c.model != "base" && cloud.contains("psi")) {  // none when the spec fixes every parameter
    c.psi_names = get_field<std::vector<std::string>>(cloud, "psi_names", path, P + "cloud.");
    if (c.psi_names.empty()) throw DataError(path, 0, P + "cloud.psi_names", "empty for model '" + c.model + "'");
    const auto rows = get_field<std::vector<std::vector<double>>>(cloud, "psi", path, P + "cloud.");
    if (rows.size() != weights.size()) {
      throw DataError(path, 0, P + "cloud.psi", "needs one row per weight (" + std::to_string(weights.size()) + ")");
    }
    c.psi.resize(static_cast<Eigen::Index>(c.psi_names.size()), static_cast<Eigen::Index>(rows.size()));
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (rows[i].size() != c.psi_names.size()) {
        throw DataError(path, 0, P + "cloud.psi[" + std::to_string(i) + "]",
                        "needs " + std::to_string(c.psi_names.size()) + " values (one per extension parameter)");
      }
      for (std::size_t k = 0; k < rows[i].size(); ++k) {
        if (!std::isfinite(rows[i][k])) throw DataError(path, 0, P + "cloud.psi[" + std::to_string(i) + "]", "holds a non-finite number");
        c.psi(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(i)) = rows[i][k];
      }
    }
  }
  return c;
}

// A file with a "checksum" must match it; one without (written before posterior files carried a
// checksum, or by hand) is read as it is. A cut file is not valid JSON, so either way damage is an
// error naming the file, never a wrong posterior.
// The member is taken out of `j` (the readers do not need it).
void check_checksum(nlohmann::json& j, const std::string& path) {
  if (!j.is_object() || !j.contains(kChecksumKey)) return;
  const nlohmann::json stored = std::move(j[kChecksumKey]);
  j.erase(kChecksumKey);
  if (!stored.is_string()) throw DataError(path, 0, kChecksumKey, "must be a string (\"fnv1a64:\" and 16 hex digits)");
  std::string computed;
  try {
    computed = content_checksum(j);
  } catch (const nlohmann::json::exception& e) {
    throw DataError(path, 0, "json", std::string("not valid JSON (") + e.what() + ")");
  }
  if (stored.get<std::string>() != computed) {
    throw DataError(path, 0, kChecksumKey,
                    "does not match the file's contents: the file was changed or damaged after it was written");
  }
}

nlohmann::json parse_json(std::istream& in, const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    // parse_error, and out_of_range for a number past a double ("2e4000", found by
    // fuzz/posterior_json_fuzzer: it escaped as an internal error).
    throw DataError(path, 0, "json", std::string("not valid JSON (") + e.what() + ")");
  }
  check_checksum(j, path);
  return j;
}

nlohmann::json parse_json_file(std::string path) {
  if (std::filesystem::is_directory(path)) path = (std::filesystem::path(path) / "posterior.json").string();
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open posterior file '" + path + "'");
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  if (!ec && bytes > kMaxPosteriorBytes) {
    throw DataError(path, 0, "size",
                    std::to_string(bytes) + " bytes, more than a posterior file may hold (" +
                        std::to_string(kMaxPosteriorBytes) + ")");
  }
  return parse_json(in, path);
}

fleet::ClassPosteriors classes_from_json(const nlohmann::json& j, const std::string& path);

// A single-class posterior; a file of classes is refused, naming them.
fleet::PosteriorCloud single_posterior(const nlohmann::json& j, const std::string& path) {
  if (j.is_object() && j.contains("classes")) {
    const fleet::ClassPosteriors classes = classes_from_json(j, path);
    throw DataError(path, 0, "classes",
                    "holds a posterior per vehicle class (" + fleet::list_labels(classes) +
                        "); this command reads a single-class posterior");
  }
  return parse_posterior_object(j, path, "");
}

std::string file_path(const std::string& path) {
  return std::filesystem::is_directory(path) ? (std::filesystem::path(path) / "posterior.json").string() : path;
}
}  // namespace

fleet::PosteriorCloud read_posterior_file(const std::string& path_in) {
  return single_posterior(parse_json_file(path_in), file_path(path_in));
}

fleet::PosteriorCloud read_posterior(std::istream& in, const std::string& path) {
  return single_posterior(parse_json(in, path), path);
}

fleet::ClassPosteriors read_posterior_classes(const std::string& path_in) {
  return classes_from_json(parse_json_file(path_in), file_path(path_in));
}

namespace {
fleet::ClassPosteriors classes_from_json(const nlohmann::json& j, const std::string& path) {
  if (!j.is_object() || !j.contains("classes")) return {fleet::ClassPosterior{"", parse_posterior_object(j, path, "")}};
  if (get_field<int>(j, "format_version", path, "") != kClassesFormatVersion) {
    throw DataError(path, 0, "format_version",
                    "unsupported version for a file of vehicle classes (this ssrfleet reads " +
                        std::to_string(kClassesFormatVersion) + ")");
  }
  const auto& list = j["classes"];
  if (!list.is_array() || list.empty()) throw DataError(path, 0, "classes", "must be a non-empty array");
  fleet::ClassPosteriors out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string P = "classes[" + std::to_string(i) + "].";
    fleet::ClassPosterior c;
    c.label = get_field<std::string>(list[i], "label", path, P);
    if (!records::is_class_label(c.label)) {
      throw DataError(path, 0, P + "label", "'" + c.label + "' is not a class label (one or more of A-Z a-z 0-9 _ . -)");
    }
    for (const auto& seen : out) {
      if (seen.label == c.label) throw DataError(path, 0, P + "label", "class '" + c.label + "' appears twice");
    }
    c.cloud = parse_posterior_object(list[i], path, P);
    if (get_field<long>(list[i], "trucks", path, P) != c.cloud.trucks_seen) {
      throw DataError(path, 0, P + "trucks", "differs from the class's trucks_seen");
    }
    if (!out.empty() && c.cloud.site_fingerprint != out.front().cloud.site_fingerprint) {
      throw DataError(path, 0, P + "site.fingerprint", "differs from the first class's: every class must be fitted on one site");
    }
    out.push_back(std::move(c));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.label < b.label; });
  return out;
}
}  // namespace

nlohmann::json posterior_classes_to_json(const fleet::ClassPosteriors& classes,
                                         const std::vector<std::vector<fleet::ParameterSummary>>& hyper,
                                         const std::vector<std::vector<fleet::ParameterSummary>>& psi) {
  if (classes.empty() || hyper.size() != classes.size() || psi.size() != classes.size()) {
    throw std::invalid_argument("io::posterior_classes_to_json(): want one summary per class");
  }
  if (fleet::unlabelled(classes)) return posterior_to_json(classes.front().cloud, hyper.front(), psi.front());
  const std::vector<double> shares = fleet::observed_shares(classes);
  long total = 0;
  for (const auto& c : classes) total += c.cloud.trucks_seen;
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t k = 0; k < classes.size(); ++k) {
    nlohmann::json e = posterior_to_json(classes[k].cloud, hyper[k], psi[k]);
    e["label"] = classes[k].label;
    e["trucks"] = classes[k].cloud.trucks_seen;
    e["share"] = shares[k];
    list.push_back(std::move(e));
  }
  nlohmann::json j;
  j["format_version"] = kClassesFormatVersion;
  j["trucks_seen"] = total;
  j["method"] = classes.front().cloud.method;
  j["site"] = list.front()["site"];
  j["classes"] = std::move(list);
  return j;
}

void write_posterior_classes_file(const std::string& path, const fleet::ClassPosteriors& classes,
                                  const std::vector<std::vector<fleet::ParameterSummary>>& hyper,
                                  const std::vector<std::vector<fleet::ParameterSummary>>& psi) {
  const std::string text = posterior_file_text(posterior_classes_to_json(classes, hyper, psi));
  write_file_atomically(path, [&](std::ostream& os) { os << text; });
}

}  // namespace ssrfleet::io
