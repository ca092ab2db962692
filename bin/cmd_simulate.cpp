// ssrfleet simulate: a fleet (drawn from distributions, or an explicit truck list) over a road,
// written as a WIM log.
#include <algorithm>
#include <charconv>
#include <cctype>
#include <iostream>
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fleet/simulator.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/force_log.hpp"
#include "io/static_weights_csv.hpp"
#include "io/truck_list_csv.hpp"
#include "io/wim_log.hpp"
#include "model/model_spec.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::cli {

namespace {
// The tyre forces the sensors read: the observed IF (model + noise) times the static wheel load.
std::vector<records::ForceRecord> to_force_records(const std::vector<records::WimRecord>& records, double unsprung_mass_kg) {
  std::vector<records::ForceRecord> out;
  out.reserve(records.size());
  for (const auto& r : records) {
    records::ForceRecord f;
    f.truck_id = r.truck_id;
    f.time_s = r.time_s;
    f.speed_mps = r.speed_mps;
    f.sprung_mass_kg = r.sprung_mass_kg;
    f.force_n = r.impact_factor * ((unsprung_mass_kg + r.sprung_mass_kg) * vehicle::gravity_mps2);
    out.push_back(std::move(f));
  }
  return out;
}

// The most trucks simulate draws (docs/site-data.md): the log of 10 million trucks is about 3 GB
// in memory while it is written.
constexpr long kMaxSimulatedTrucks = 10'000'000;

// --fleet-mix "A:share=0.6,k-mean=400e3;B:share=0.4": each class's share (required) and the
// fleet parameters it changes from `base` (the command's own --k-mean, ...), named as those options.
std::vector<fleet::ClassFleet> parse_fleet_mix(const std::string& text, const fleet::FleetDistribution& base) {
  const auto bad = [&](const std::string& why) {
    return UsageError("--fleet-mix '" + text + "': " + why +
                      " (expected LABEL:share=S[,PARAM=VALUE...];LABEL:..., PARAM one of m2-mean, m2-sd, k-mean, k-sd, "
                      "kt-mean, kt-sd, speed-mean, speed-sd, z-mean, z-sd)");
  };
  std::vector<fleet::ClassFleet> out;
  std::stringstream classes(text);
  std::string item;
  while (std::getline(classes, item, ';')) {
    const auto colon = item.find(':');
    fleet::ClassFleet c;
    c.label = item.substr(0, colon);
    c.distribution = base;
    c.share = -1.0;
    if (colon == std::string::npos) throw bad("class '" + c.label + "' has no share");
    std::stringstream params(item.substr(colon + 1));
    std::string kv;
    while (std::getline(params, kv, ',')) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos) throw bad("'" + kv + "' is not PARAM=VALUE");
      const std::string key = kv.substr(0, eq), value = kv.substr(eq + 1);
      double x = 0.0;
      try {
        std::size_t used = 0;
        x = std::stod(value, &used);
        if (used != value.size()) throw std::invalid_argument(value);
      } catch (const std::logic_error&) {
        throw bad("'" + value + "' is not a number");
      }
      auto& d = c.distribution;
      if (key == "share") c.share = x;
      else if (key == "m2-mean") d.sprung_mass_kg.mean = x;
      else if (key == "m2-sd") d.sprung_mass_kg.sd = x;
      else if (key == "k-mean") d.stiffness_npm.mean = x;
      else if (key == "k-sd") d.stiffness_npm.sd = x;
      else if (key == "kt-mean") d.tyre_stiffness_npm.mean = x;
      else if (key == "kt-sd") d.tyre_stiffness_npm.sd = x;
      else if (key == "speed-mean") d.speed_mps.mean = x;
      else if (key == "speed-sd") d.speed_mps.sd = x;
      else if (key == "z-mean") d.lateral_m.mean = x;
      else if (key == "z-sd") d.lateral_m.sd = x;
      else throw bad("unknown parameter '" + key + "'");
    }
    if (c.share < 0.0) throw bad("class '" + c.label + "' has no share (share=S, S >= 0)");
    out.push_back(std::move(c));
  }
  if (out.empty()) throw bad("no classes");
  return out;
}

bool is_count(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}
}  // namespace

int run_simulate(int argc, const char* const argv[]) {
  std::string road = "AS1", trucks_arg = "100", out = "-", truth, seed_text = "1", effect;
  std::string static_weights, fleet_mix;
  double noise = 0.02;
  bool quiet = false, forces = false, no_sprung_mass = false;
  SiteFlags site_flags;
  fleet::FleetDistribution dist;
  po::options_description desc("simulate options");
  desc.add_options()
      ("help,h", "show this help")
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("trucks", po::value(&trucks_arg)->value_name("N|FILE")->default_value(trucks_arg),
       "number of trucks to draw from the fleet distribution, or a truck-list CSV file")
      ("noise", po::value(&noise)->value_name("SD")->default_value(noise), "measurement noise sd sigma_IF; 0 = exact model output")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text),
       "random seed (fleet draw and noise; a whole number)")
      ("out,o", po::value(&out)->value_name("FILE")->default_value(out), "WIM log to write ('-' = standard output)")
      ("truth", po::value(&truth)->value_name("FILE"),
       "also write the simulated trucks as they drove (truck-list CSV; with second_class, its stiffnesses) here")
      ("model", po::value(&effect)->value_name("SPEC"),
       "simulate with effects the base model leaves out: effects joined by '+', each NAME:param=value,... with every "
       "parameter given, e.g. sensor_gain:sensor=5,gain=1.05+tyre_damping:c_t=400 (ssrfleet effects lists them)")
      ("effect", po::value(&effect)->value_name("SPEC"), "the same as --model (one effect or several joined by '+')")
      ("forces", po::bool_switch(&forces),
       "log raw tyre forces force_1..force_M (N) instead of impact factors: a log for `ssrfleet weigh`")
      ("no-sprung-mass", po::bool_switch(&no_sprung_mass),
       "with --forces, leave the sprung_mass_kg column out (the static weight is what weigh estimates)")
      ("fleet-mix", po::value(&fleet_mix)->value_name("MIX"),
       "a fleet of vehicle classes, e.g. \"A:share=0.6,k-mean=400e3;B:share=0.4,k-mean=600e3\": each class's traffic "
       "share (the shares summing to 1) and the fleet parameters below that it changes (k-mean, m2-sd, ...); each "
       "truck's class is drawn by share and written in the log's class column (and the truth list's)")
      ("static-weights", po::value(&static_weights)->value_name("FILE"),
       "also write each truck's true static wheel load here (truck_id,static_kn,sprung_mass_kg)")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  site_flags.add_to(desc);
  po::options_description fleet_desc("Fleet distribution (paper Table 1)");
  const auto number = [](double& value, const char* name) {
    return po::value(&value)->value_name(name)->default_value(value, shortest_text(value));
  };
  fleet_desc.add_options()
      ("m2-mean", number(dist.sprung_mass_kg.mean, "KG"), "sprung mass mean (kg)")
      ("m2-sd", number(dist.sprung_mass_kg.sd, "KG"), "sprung mass sd (kg)")
      ("k-mean", number(dist.stiffness_npm.mean, "N/M"), "suspension stiffness mean (N/m)")
      ("k-sd", number(dist.stiffness_npm.sd, "N/M"), "suspension stiffness sd (N/m)")
      ("kt-mean", number(dist.tyre_stiffness_npm.mean, "N/M"), "tyre stiffness mean (N/m)")
      ("kt-sd", number(dist.tyre_stiffness_npm.sd, "N/M"), "tyre stiffness sd (N/m)")
      ("speed-mean", number(dist.speed_mps.mean, "M/S"), "speed mean (m/s)")
      ("speed-sd", number(dist.speed_mps.sd, "M/S"), "speed sd (m/s)")
      ("z-mean", number(dist.lateral_m.mean, "M"), "lateral position mean (m)")
      ("z-sd", number(dist.lateral_m.sd, "M"), "lateral position sd (m)");
  desc.add(fleet_desc);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet simulate [--road ROAD] [--trucks N|FILE] [--noise SD] [--seed SEED] [--model SPEC] "
                     "[--out FILE]\n"
                     "ssrfleet simulate --forces [--no-sprung-mass] [--static-weights FILE] [...]",
                     "The log starts with a comment line naming the road, trucks, noise, seed, site and model.")) {
    return 0;
  }
  const std::uint64_t seed = parse_seed(seed_text);
  if (!(noise >= 0.0)) throw UsageError("--noise " + std::to_string(noise) + ": must be >= 0");
  if (no_sprung_mass && !forces) throw UsageError("--no-sprung-mass needs --forces (an IF log needs the mass that normalises it)");

  // A count is checked before anything is built (the road takes a while), so an absurd one fails at once.
  long count = 0;
  if (is_count(trucks_arg)) {
    unsigned long long n = 0;  // digits only (is_count); from_chars reports a number past 2^64 as out of range
    const auto [end, ec] = std::from_chars(trucks_arg.data(), trucks_arg.data() + trucks_arg.size(), n);
    if (ec != std::errc() || n < 1 || n > static_cast<unsigned long long>(kMaxSimulatedTrucks)) {
      throw UsageError("--trucks " + trucks_arg + ": must be between 1 and " + std::to_string(kMaxSimulatedTrucks));
    }
    count = static_cast<long>(n);
  }
  const site::Site site(site::load_road(road, &std::cerr), site_flags.to_options());
  std::vector<records::Truck> trucks;
  if (count > 0) {
    trucks = fleet_mix.empty()
                 ? fleet::draw_fleet(dist, static_cast<int>(count), site.lateral_min_m(), site.lateral_max_m(), seed)
                 : fleet::draw_class_fleet(parse_fleet_mix(fleet_mix, dist), static_cast<int>(count),
                                           site.lateral_min_m(), site.lateral_max_m(), seed);
  } else {
    if (!fleet_mix.empty()) throw UsageError("--fleet-mix draws the trucks: give --trucks N (a truck list may carry a class column instead)");
    trucks = io::read_truck_list_file(trucks_arg, site.lateral_min_m(), site.lateral_max_m());
  }
  const fleet::SimulationModel setting = fleet::parse_simulation_model(effect, site);
  const fleet::SimulatedLog log = setting.extension ? fleet::simulate_log(site, trucks, noise, seed, *setting.extension, setting.psi)
                                                    : fleet::simulate_log(site, trucks, noise, seed);

  write_output(out, [&](std::ostream& os) {
    os << "# ssrfleet " << SSRFLEET_VERSION << " simulate: road " << site.surface().name << ", "
       << trucks.size() << " trucks, noise " << noise << ", seed " << seed << ", site " << site.fingerprint()
       << (setting.extension ? ", model " + setting.text : "") << "\n";
    if (forces) {
      io::write_force_log(os, to_force_records(log.records, site.options().unsprung_mass_kg), !no_sprung_mass);
    } else {
      io::write_wim_log(os, log.records);
    }
  });
  if (!static_weights.empty()) {
    write_output(static_weights,
                 [&](std::ostream& os) { io::write_true_static_weights_csv(os, log.trucks, site.options().unsprung_mass_kg); });
  }
  if (!truth.empty()) write_output(truth, [&](std::ostream& os) { io::write_truck_list(os, log.trucks); });

  if (log.lift_offs > 0) {
    std::cerr << "ssrfleet simulate: warning: " << log.lift_offs
              << " truck(s) lost tyre contact (IF < 0) somewhere on the road; minimum IF "
              << log.min_if.minCoeff() << "\n";
  }
  if (!quiet) {
    std::cerr << "ssrfleet simulate: " << trucks.size() << " trucks on road " << site.surface().name << " ("
              << site.sensors() << " sensors), noise sd " << noise << ", seed " << seed << " -> "
              << (out == "-" ? std::string("stdout") : out) << "\n";
  }
  return 0;
}

}  // namespace ssrfleet::cli
