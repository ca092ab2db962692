// The posterior file: the summary of docs/outputs.md (per hyperparameter mean, sd, q025, q975;
// trucks seen, particles, ESS, log-evidence) followed by the weighted draws that `predict`
// reads ("cloud"), and the identity of the site it was fitted on. This file only formats: the
// summary is computed by fleet::summarise_cloud (fleet/posterior_summary.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <istream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleet/posterior_cloud.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/vehicle_classes.hpp"

namespace ssrfleet::io {

// What a posterior file may be (docs/outputs.md). The default fit (1,024 particles, 10,000
// trucks in the pool) writes about 0.7 MB; 10^6 particles, about 150 MB. A larger file is refused
// before a byte is parsed (a DataError naming the file and "size"), not read into memory.
inline constexpr std::uintmax_t kMaxPosteriorBytes = std::uintmax_t{1} << 30;
// Sites of a fit over several (site.sites): a road authority's network is tens to hundreds.
inline constexpr std::size_t kMaxPosteriorSites = 100000;

// The whole file as JSON (summary + cloud). `hyper` is fleet::summarise_cloud(cloud): one entry
// per hyperparameter (fleet_model.hpp order); `psi` is fleet::summarise_psi(cloud), one entry per
// extension parameter (none for the base model); another length is std::invalid_argument.
// The model is recorded as "model" (its spec), with the extension's parameters summarised under
// "extension" by name, and their draws as cloud.psi (one row per draw, like cloud.theta; the
// columns' names in cloud.psi_names). A model whose parameters are all fixed has no ψ draws.
nlohmann::json posterior_to_json(const fleet::PosteriorCloud& cloud,
                                 const std::vector<fleet::ParameterSummary>& hyper,
                                 const std::vector<fleet::ParameterSummary>& psi = {});

// The text of a posterior file: `j` (from posterior_to_json or posterior_classes_to_json) with a
// "checksum" member added, FNV-1a 64 of the canonical compact dump of everything else, indented.
// Every writer of a posterior file writes this text; a reader refuses a file whose checksum does
// not match (a DataError naming the file and the field "checksum") and reads one without a
// checksum as it is (older files, hand-made ones).
std::string posterior_file_text(nlohmann::json j);

// Reads a posterior file, or the file `posterior.json` inside a directory (a stream's state
// directory). Any missing or malformed field is a DataError naming the file and the field; a
// missing file is a MissingInputError. A file of several vehicle classes is a DataError (field
// "classes") naming them: read it with read_posterior_classes.
fleet::PosteriorCloud read_posterior_file(const std::string& path);
// The same from a stream; `source` names it in messages.
fleet::PosteriorCloud read_posterior(std::istream& in, const std::string& source);

void write_posterior_file(const std::string& path, const fleet::PosteriorCloud& cloud,
                          const std::vector<fleet::ParameterSummary>& hyper,
                          const std::vector<fleet::ParameterSummary>& psi = {});

// A posterior per vehicle class (fleet/vehicle_classes.hpp). The file is
//   {"format_version": 2, "trucks_seen": N, "site": {...}, "method": ...,
//    "classes": [{"label": "A", "trucks": n_A, "share": n_A / N, ...the single-class object...}, ...]}
// each class entry being exactly what posterior_to_json writes for that class's cloud, plus its
// label, truck count and observed traffic share. An unlabelled fit (one class, empty label) is
// written as the single-class file of posterior_to_json, unchanged. `hyper[c]`, `psi[c]` are the
// summaries of class c.
nlohmann::json posterior_classes_to_json(const fleet::ClassPosteriors& classes,
                                         const std::vector<std::vector<fleet::ParameterSummary>>& hyper,
                                         const std::vector<std::vector<fleet::ParameterSummary>>& psi);
void write_posterior_classes_file(const std::string& path, const fleet::ClassPosteriors& classes,
                                  const std::vector<std::vector<fleet::ParameterSummary>>& hyper,
                                  const std::vector<std::vector<fleet::ParameterSummary>>& psi);

// Reads either kind of posterior file (or a state directory's posterior.json): a single-class
// file as one class with the empty label, a classes file as its classes sorted by label. Errors as
// read_posterior_file, a class's fields named "classes[i].field".
fleet::ClassPosteriors read_posterior_classes(const std::string& path);

}  // namespace ssrfleet::io
