#include "model/model_spec.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "model/composed_extension.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

namespace {

constexpr double kFree = std::numeric_limits<double>::quiet_NaN();

[[noreturn]] void spec_error(const std::string& spec, const std::string& what, const site::Site& site) {
  throw UsageError("model '" + spec + "': " + what + "\nthe catalogue (effects joined by '+', each NAME or " +
                   "NAME:param=value,...; a parameter given is fixed, one left out is fitted):\n" +
                   model_catalogue(site));
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!text.empty() && text.back() == sep) parts.emplace_back();
  return parts;
}

// One effect of a spec: the extension, its parameters' fixed values (NaN = free) and the
// canonical text of the effect.
struct ParsedEffect {
  ExtensionComponent component;
  std::string text;
};

ParsedEffect parse_effect(const std::string& spec, const std::string& item, const site::Site& site) {
  const auto colon = item.find(':');
  const std::string name = item.substr(0, colon);
  const auto names = extension_names();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    spec_error(spec, name.empty() ? "an effect has no name" : "unknown effect '" + name + "'", site);
  }
  ParsedEffect out;
  out.component.extension = make_extension(name, site);
  const auto& params = out.component.extension->parameters();
  out.component.fixed.assign(params.size(), kFree);
  std::vector<std::string> given_text(params.size());
  if (colon != std::string::npos) {
    for (const std::string& assignment : split(item.substr(colon + 1), ',')) {
      const auto eq = assignment.find('=');
      const std::string key = assignment.substr(0, eq);
      const auto p = std::find_if(params.begin(), params.end(), [&](const auto& q) { return q.name == key; });
      if (eq == std::string::npos || p == params.end()) {
        spec_error(spec, "'" + assignment + "' is not param=value with param a parameter of " + name, site);
      }
      const auto j = static_cast<std::size_t>(p - params.begin());
      const std::string value_text = assignment.substr(eq + 1);
      double value = std::numeric_limits<double>::quiet_NaN();
      try {
        std::size_t used = 0;
        value = std::stod(value_text, &used);
        if (used != value_text.size()) value = std::numeric_limits<double>::quiet_NaN();
      } catch (const std::exception&) {
      }
      if (!(value >= p->lo && value <= p->hi)) {
        std::ostringstream os;
        os << name << "." << key << " = '" << value_text << "' must be a number in [" << p->lo << ", " << p->hi << "]";
        spec_error(spec, os.str(), site);
      }
      if (!std::isnan(out.component.fixed[j])) spec_error(spec, name + "." + key + " is given twice", site);
      out.component.fixed[j] = value;
      given_text[j] = value_text;
    }
  }
  out.text = name;
  std::string assignments;
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (given_text[j].empty()) continue;
    assignments += (assignments.empty() ? "" : ",") + params[j].name + "=" + given_text[j];
  }
  if (!assignments.empty()) out.text += ":" + assignments;
  return out;
}

std::vector<ParsedEffect> parse_effects(const std::string& text, const site::Site& site) {
  std::vector<ParsedEffect> effects;
  for (const std::string& item : split(text, '+')) {
    effects.push_back(parse_effect(text, item, site));
    for (std::size_t e = 0; e + 1 < effects.size(); ++e) {
      if (effects[e].component.extension->name() == effects.back().component.extension->name()) {
        spec_error(text, "effect " + effects.back().component.extension->name() + " is named twice", site);
      }
    }
  }
  const auto replaces_stiffness = [](const ParsedEffect& e) { return e.component.extension->edits_stiffness_distribution(); };
  if (std::count_if(effects.begin(), effects.end(), replaces_stiffness) > 1) {
    spec_error(text, "more than one effect replaces the fleet's stiffness distribution; choose one", site);
  }
  return effects;
}

std::string joined_text(const std::vector<ParsedEffect>& effects) {
  std::string s;
  for (const auto& e : effects) s += (s.empty() ? "" : "+") + e.text;
  return s;
}

}  // namespace

std::string model_catalogue(const site::Site& site) {
  std::ostringstream os;
  for (const auto& name : extension_names()) {
    const auto e = make_extension(name, site);
    os << "  " << name << ": " << e->description() << ";";
    const auto& ps = e->parameters();
    for (std::size_t j = 0; j < ps.size(); ++j) {
      os << (j ? "," : "") << " " << ps[j].name << " [" << ps[j].lo << ", " << ps[j].hi << "]"
         << (ps[j].unit.empty() ? "" : " " + ps[j].unit);
    }
    os << "\n";
  }
  return os.str();
}

ModelSpec parse_model_spec(const std::string& text, const site::Site& site) {
  ModelSpec spec;
  if (text.empty() || text == "base") return spec;
  auto effects = parse_effects(text, site);
  spec.text = joined_text(effects);
  const bool nothing_fixed = std::all_of(effects.front().component.fixed.begin(), effects.front().component.fixed.end(),
                                         [](double v) { return std::isnan(v); });
  if (effects.size() == 1 && nothing_fixed) {
    spec.extension = std::move(effects.front().component.extension);
    return spec;
  }
  std::vector<ExtensionComponent> components;
  for (auto& e : effects) components.push_back(std::move(e.component));
  spec.extension = std::make_unique<ComposedExtension>(spec.text, std::move(components));
  return spec;
}

SimulationModel parse_simulation_model(const std::string& text, const site::Site& site) {
  SimulationModel out;
  if (text.empty() || text == "base") return out;
  auto effects = parse_effects(text, site);
  out.text = joined_text(effects);
  std::string missing;
  for (const auto& e : effects) {
    const auto& ps = e.component.extension->parameters();
    for (std::size_t j = 0; j < ps.size(); ++j) {
      if (std::isnan(e.component.fixed[j])) missing += (missing.empty() ? "" : ", ") + e.component.extension->name() + "." + ps[j].name;
    }
  }
  if (!missing.empty()) spec_error(text, "a simulation needs every parameter; missing: " + missing, site);
  if (effects.size() == 1) {  // the catalogue's own extension at ψ: the same bits as simulate --effect
    out.psi = effects.front().component.fixed;
    out.extension = std::move(effects.front().component.extension);
    return out;
  }
  std::vector<ExtensionComponent> components;
  for (auto& e : effects) components.push_back(std::move(e.component));
  out.extension = std::make_unique<ComposedExtension>(out.text, std::move(components));
  return out;
}

}  // namespace ssrfleet::fleet
