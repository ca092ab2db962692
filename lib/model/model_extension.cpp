#include "model/model_extension.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "model/fleet_model.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {
// Function-local so registrars in other translation units can use it during static
// initialisation, whatever the order.
std::map<std::string, ExtensionFactory>& registry() {
  static std::map<std::string, ExtensionFactory> factories;
  return factories;
}

std::string catalogue_list() {
  std::string s;
  for (const auto& name : extension_names()) {
    if (!s.empty()) s += ", ";
    s += name;
  }
  return s;
}
}  // namespace

bool ModelExtension::in_prior(const double* psi) const {
  const auto& ps = parameters();
  for (std::size_t j = 0; j < ps.size(); ++j) {
    if (!(psi[j] >= ps[j].lo && psi[j] <= ps[j].hi)) return false;
  }
  return true;
}

double ModelExtension::log_prior(const double* psi) const {
  if (!in_prior(psi)) return -std::numeric_limits<double>::infinity();
  double lp = 0.0;
  for (const auto& p : parameters()) lp -= std::log(p.hi - p.lo);
  return lp;
}

std::vector<ModelExtension::StiffnessComponent> ModelExtension::stiffness_mixture(const double* /*psi*/, double mean_npm,
                                                                                 double sd_npm) const {
  return {{1.0, mean_npm, sd_npm}};
}

void ModelExtension::to_move_coordinates(const double* psi, double* u) const {
  std::copy(psi, psi + dim(), u);
}

void ModelExtension::from_move_coordinates(const double* u, double* psi) const {
  std::copy(u, u + dim(), psi);
}

std::vector<double> ModelExtension::move_coordinate_spans() const {
  const auto& params = parameters();
  std::vector<double> at(params.size()), u_lo(params.size()), u_hi(params.size()), spans(params.size());
  for (std::size_t j = 0; j < params.size(); ++j) at[j] = params[j].null_value;
  for (std::size_t j = 0; j < params.size(); ++j) {
    std::vector<double> edge = at;
    edge[j] = params[j].lo;
    to_move_coordinates(edge.data(), u_lo.data());
    edge[j] = params[j].hi;
    to_move_coordinates(edge.data(), u_hi.data());
    spans[j] = std::abs(u_hi[j] - u_lo[j]);
  }
  return spans;
}

double ModelExtension::log_stiffness_density(const double* /*psi*/, double k, double mean_npm, double sd_npm) const {
  return log_normal_density(k, mean_npm, sd_npm);
}

double ModelExtension::stiffness_cdf(const double* /*psi*/, double k, double mean_npm, double sd_npm) const {
  return normal_cdf((k - mean_npm) / sd_npm);
}

double ModelExtension::draw_stiffness(const double* /*psi*/, double mean_npm, double sd_npm, double /*uniform*/,
                                      double standard_normal) const {
  return mean_npm + sd_npm * standard_normal;
}

ExtensionRegistrar::ExtensionRegistrar(std::string name, ExtensionFactory factory) {
  registry()[std::move(name)] = std::move(factory);
}

std::vector<std::string> extension_names() {
  std::vector<std::string> names;
  for (const auto& [name, factory] : registry()) names.push_back(name);
  return names;
}

std::unique_ptr<ModelExtension> make_extension(const std::string& name, const site::Site& site) {
  const auto it = registry().find(name);
  if (it == registry().end()) {
    throw UsageError("unknown model extension '" + name + "'; the catalogue has: " + catalogue_list());
  }
  return it->second(site);
}

ExtensionSetting parse_extension_setting(const std::string& text, const site::Site& site) {
  const auto colon = text.find(':');
  ExtensionSetting out;
  out.extension = make_extension(text.substr(0, colon), site);
  const auto& params = out.extension->parameters();
  std::vector<bool> given(params.size(), false);
  out.psi.assign(params.size(), 0.0);
  std::stringstream items(colon == std::string::npos ? std::string() : text.substr(colon + 1));
  std::string item;
  while (std::getline(items, item, ',')) {
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const auto p = std::find_if(params.begin(), params.end(), [&](const auto& q) { return q.name == key; });
    if (eq == std::string::npos || p == params.end()) {
      std::string names;
      for (const auto& q : params) {
        if (!names.empty()) names += ", ";
        names += q.name;
      }
      throw UsageError("effect '" + text + "': '" + item + "' is not NAME=VALUE with NAME one of " + names);
    }
    const auto j = static_cast<std::size_t>(p - params.begin());
    double value = std::numeric_limits<double>::quiet_NaN();
    try {
      std::size_t used = 0;
      value = std::stod(item.substr(eq + 1), &used);
      if (used != item.size() - eq - 1) value = std::numeric_limits<double>::quiet_NaN();
    } catch (const std::exception&) {
    }
    if (!(value >= p->lo && value <= p->hi)) {
      std::ostringstream os;
      os << "effect '" << text << "': " << key << " must be a number in [" << p->lo << ", " << p->hi << "]";
      throw UsageError(os.str());
    }
    if (given[j]) throw UsageError("effect '" + text + "': " + key + " is given twice");
    given[j] = true;
    out.psi[j] = value;
  }
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (!given[j]) throw UsageError("effect '" + text + "': parameter " + params[j].name + " is missing");
  }
  return out;
}

}  // namespace ssrfleet::fleet
