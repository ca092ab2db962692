#include "io/posterior_convergence_json.hpp"

#include <cmath>

#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
// ESS and R̂ are NaN for a parameter pinned at one value (no variation to measure): null in JSON.
nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

double number_at(const nlohmann::json& e, const char* key, const std::string& path, const std::string& where) {
  if (!e.contains(key)) throw DataError(path, 0, where + key, "missing");
  const auto& v = e[key];
  if (v.is_null()) return NAN;
  if (!v.is_number() || !std::isfinite(v.get<double>())) throw DataError(path, 0, where + key, "must be a number or null");
  return v.get<double>();
}
}  // namespace

void write_convergence(const fleet::PosteriorCloud& c, nlohmann::json& j) {
  if (c.chains <= 1 && c.convergence.empty()) return;
  j["chains"] = c.chains;
  nlohmann::json out = nlohmann::json::object();
  for (const auto& p : c.convergence) {
    out[p.name] = {{"rhat", number_or_null(p.rhat)},           {"ess_bulk", number_or_null(p.ess_bulk)},
                   {"ess_tail", number_or_null(p.ess_tail)},   {"mcse_mean", number_or_null(p.mcse_mean)},
                   {"mcse_q05", number_or_null(p.mcse_q05)},   {"mcse_q95", number_or_null(p.mcse_q95)}};
    if (std::isfinite(p.ess_equivalent)) out[p.name]["ess_equivalent"] = p.ess_equivalent;
  }
  j["convergence"] = std::move(out);
}

void read_convergence(const nlohmann::json& j, const std::string& path, const std::string& P, fleet::PosteriorCloud& c) {
  c.chains = 1;
  c.convergence.clear();
  if (j.contains("chains")) {
    const auto& v = j["chains"];
    if (!v.is_number_integer() || v.get<long long>() < 1 || v.get<long long>() > 64) {
      throw DataError(path, 0, P + "chains", "must be a whole number from 1 to 64");
    }
    c.chains = v.get<int>();
  }
  if (!j.contains("convergence")) return;
  const auto& all = j["convergence"];
  if (!all.is_object()) throw DataError(path, 0, P + "convergence", "must be an object of parameters");
  for (auto it = all.begin(); it != all.end(); ++it) {
    const std::string where = P + "convergence." + it.key() + ".";
    if (!it.value().is_object()) throw DataError(path, 0, P + "convergence." + it.key(), "must be an object");
    fleet::ParameterConvergence p;
    p.name = it.key();
    p.rhat = number_at(it.value(), "rhat", path, where);
    p.ess_bulk = number_at(it.value(), "ess_bulk", path, where);
    p.ess_tail = number_at(it.value(), "ess_tail", path, where);
    p.mcse_mean = number_at(it.value(), "mcse_mean", path, where);
    p.mcse_q05 = number_at(it.value(), "mcse_q05", path, where);
    p.mcse_q95 = number_at(it.value(), "mcse_q95", path, where);
    // SMC runs' only (MCMC chains' files leave it out).
    p.ess_equivalent = it.value().contains("ess_equivalent") ? number_at(it.value(), "ess_equivalent", path, where) : NAN;
    c.convergence.push_back(p);
  }
}

}  // namespace ssrfleet::io
