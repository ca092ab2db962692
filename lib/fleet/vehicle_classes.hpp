// Vehicle classes: one independent fleet posterior per class, combined as a
// mixture by traffic share. A log without labels is one class with the empty label, and every
// command then behaves exactly as before classes existed.
//
// Reproducibility: each class's sampler and predictive draws are seeded from the user's seed and
// the class label (class_seed), never from the order in which classes appear, so a class's
// posterior does not depend on the other classes in the log or on how records interleave.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "fleet/posterior_cloud.hpp"
#include "model/fleet_distribution.hpp"
#include "records/truck.hpp"
#include "records/wim_record.hpp"

namespace ssrfleet::fleet {

// One class's posterior; its truck count is cloud.trucks_seen.
struct ClassPosterior {
  std::string label;  // "" = an unlabelled log (the only class)
  PosteriorCloud cloud;
};

// Sorted by label; a file without classes reads as one entry with the empty label.
using ClassPosteriors = std::vector<ClassPosterior>;

// True when the posteriors are an unlabelled fit (one class, empty label): today's behaviour.
bool unlabelled(const ClassPosteriors& classes);

// The seed of one class: a fixed mix (splitmix64) of the seed and an FNV-1a 64 hash of the label.
// The empty label (an unlabelled log) keeps the seed itself.
std::uint64_t class_seed(std::uint64_t seed, const std::string& label);

// The records of each class, each class in the log's order; keys sorted by label.
std::map<std::string, std::vector<records::WimRecord>> split_by_class(const std::vector<records::WimRecord>& records);

// "A, B, K" for messages.
std::string list_labels(const ClassPosteriors& classes);

// The observed traffic shares: each class's trucks over all trucks.
std::vector<double> observed_shares(const ClassPosteriors& classes);

// Shares from the user's mix (label, share): every label must be a class (UsageError listing the
// known labels otherwise), each share >= 0 and finite, labels not repeated, the shares summing to 1
// within 1e-6; a class left out has share 0. An empty mix gives observed_shares.
std::vector<double> class_shares(const ClassPosteriors& classes, const std::vector<std::pair<std::string, double>>& mix);

// Parses "A=0.7,B=0.3" (UsageError naming `option` when malformed); "" = empty.
std::vector<std::pair<std::string, double>> parse_mix(const std::string& text, const std::string& option = "--mix");

// The one class named `label` alone (UsageError listing the known labels when there is none).
ClassPosteriors select_class(const ClassPosteriors& classes, const std::string& label);

// A mixed fleet to simulate: each class's traffic share and its own fleet distribution.
struct ClassFleet {
  std::string label;
  double share = 0.0;
  FleetDistribution distribution;
};

// n trucks of a mixed fleet, ids T0001.. in order: each truck's class drawn independently with
// probability share (the shares >= 0, summing to 1 within 1e-6, labels distinct: UsageError
// otherwise), then class c's n_c trucks drawn from its distribution with the seed
// class_seed(seed, label) (fleet_distribution.hpp draw_fleet), in that order. Each truck carries
// its class.
std::vector<records::Truck> draw_class_fleet(const std::vector<ClassFleet>& classes, int n, double lateral_min_m,
                                             double lateral_max_m, std::uint64_t seed);

}  // namespace ssrfleet::fleet
