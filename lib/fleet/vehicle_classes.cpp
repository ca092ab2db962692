#include "fleet/vehicle_classes.hpp"

#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/uniform_01.hpp>

#include "records/vehicle_class.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

bool unlabelled(const ClassPosteriors& classes) { return classes.size() == 1 && classes.front().label.empty(); }

std::uint64_t class_seed(std::uint64_t seed, const std::string& label) {
  if (label.empty()) return seed;
  std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a 64
  for (const unsigned char c : label) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  std::uint64_t z = seed + 0x9e3779b97f4a7c15ULL * (h | 1);  // splitmix64's finaliser
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::map<std::string, std::vector<records::WimRecord>> split_by_class(const std::vector<records::WimRecord>& records) {
  std::map<std::string, std::vector<records::WimRecord>> out;
  for (const auto& r : records) out[r.vehicle_class].push_back(r);
  return out;
}

std::string list_labels(const ClassPosteriors& classes) {
  std::string s;
  for (const auto& c : classes) s += (s.empty() ? "" : ", ") + (c.label.empty() ? std::string("(unlabelled)") : c.label);
  return s;
}

std::vector<double> observed_shares(const ClassPosteriors& classes) {
  double total = 0.0;
  for (const auto& c : classes) total += static_cast<double>(c.cloud.trucks_seen);
  std::vector<double> shares;
  for (const auto& c : classes) {
    shares.push_back(total > 0.0 ? static_cast<double>(c.cloud.trucks_seen) / total : 1.0 / static_cast<double>(classes.size()));
  }
  return shares;
}

std::vector<double> class_shares(const ClassPosteriors& classes, const std::vector<std::pair<std::string, double>>& mix) {
  if (mix.empty()) return observed_shares(classes);
  std::vector<double> shares(classes.size(), 0.0);
  std::set<std::string> named;
  double sum = 0.0;
  for (const auto& [label, share] : mix) {
    std::size_t k = 0;
    while (k < classes.size() && classes[k].label != label) ++k;
    if (k == classes.size()) {
      throw UsageError("--mix: class '" + label + "' is not in the posterior; its classes are " + list_labels(classes));
    }
    if (!named.insert(label).second) throw UsageError("--mix: class '" + label + "' is given twice");
    if (!(share >= 0.0) || !std::isfinite(share)) {
      throw UsageError("--mix: the share of class '" + label + "' must be a finite number >= 0");
    }
    shares[k] = share;
    sum += share;
  }
  if (std::abs(sum - 1.0) > 1e-6) {
    std::ostringstream os;
    os.precision(10);
    os << "--mix: the shares sum to " << sum << ", but must sum to 1 (within 1e-6)";
    throw UsageError(os.str());
  }
  return shares;
}

std::vector<std::pair<std::string, double>> parse_mix(const std::string& text, const std::string& option) {
  std::vector<std::pair<std::string, double>> mix;
  if (text.empty()) return mix;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    const std::string label = item.substr(0, eq);
    if (eq == std::string::npos || !records::is_class_label(label)) {
      throw UsageError(option + " '" + text + "': expected LABEL=SHARE,..., e.g. A=0.7,B=0.3");
    }
    const std::string value = item.substr(eq + 1);
    try {
      std::size_t used = 0;
      const double share = std::stod(value, &used);
      if (used != value.size()) throw std::invalid_argument(value);
      mix.emplace_back(label, share);
    } catch (const std::logic_error&) {
      throw UsageError(option + " '" + text + "': '" + value + "' is not a number");
    }
  }
  return mix;
}

ClassPosteriors select_class(const ClassPosteriors& classes, const std::string& label) {
  for (const auto& c : classes) {
    if (c.label == label) return {c};
  }
  throw UsageError("--class '" + label + "' is not in the posterior; its classes are " + list_labels(classes));
}

std::vector<records::Truck> draw_class_fleet(const std::vector<ClassFleet>& classes, int n, double lateral_min_m,
                                             double lateral_max_m, std::uint64_t seed) {
  if (classes.empty()) throw UsageError("a mixed fleet needs at least one class");
  if (n < 1) throw UsageError("fleet: number of trucks is " + std::to_string(n) + ", but must be at least 1");
  double sum = 0.0;
  std::set<std::string> labels;
  for (const auto& c : classes) {
    if (!records::is_class_label(c.label)) throw UsageError("class label '" + c.label + "': one or more of A-Z a-z 0-9 _ . -");
    if (!labels.insert(c.label).second) throw UsageError("class '" + c.label + "' is given twice");
    if (!(c.share >= 0.0) || !std::isfinite(c.share)) throw UsageError("class '" + c.label + "': share must be >= 0");
    c.distribution.validate();
    sum += c.share;
  }
  if (std::abs(sum - 1.0) > 1e-6) {
    std::ostringstream os;
    os.precision(10);
    os << "the classes' shares sum to " << sum << ", but must sum to 1 (within 1e-6)";
    throw UsageError(os.str());
  }
  // Each truck's class: one uniform each, from an engine of its own (the classes' draws have theirs).
  boost::random::mt19937_64 engine(seed ^ 0x636c61737365ULL /* "classe" */);
  boost::random::uniform_01<double> unif;
  std::vector<std::size_t> class_of(static_cast<std::size_t>(n));
  std::vector<int> count(classes.size(), 0);
  for (auto& k : class_of) {
    const double u = unif(engine) * sum;
    double cum = 0.0;
    k = classes.size() - 1;
    for (std::size_t c = 0; c < classes.size(); ++c) {
      cum += classes[c].share;
      if (u < cum) {
        k = c;
        break;
      }
    }
    while (classes[k].share == 0.0) --k;  // u at the very top: the last class with a share
    ++count[k];
  }
  std::vector<std::vector<records::Truck>> drawn(classes.size());
  for (std::size_t c = 0; c < classes.size(); ++c) {
    if (count[c] > 0) {
      drawn[c] = draw_fleet(classes[c].distribution, count[c], lateral_min_m, lateral_max_m,
                            class_seed(seed, classes[c].label));
    }
  }
  std::vector<records::Truck> out;
  out.reserve(class_of.size());
  std::vector<std::size_t> next(classes.size(), 0);
  for (std::size_t i = 0; i < class_of.size(); ++i) {
    const std::size_t c = class_of[i];
    records::Truck t = drawn[c][next[c]++];
    char id[32];
    std::snprintf(id, sizeof id, "T%04zu", i + 1);
    t.truck_id = id;
    t.vehicle_class = classes[c].label;
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace ssrfleet::fleet
