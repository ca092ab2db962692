#include "cli_common.hpp"

#include <charconv>
#include <cmath>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>

#include "fleet/joint_sites.hpp"
#include "io/atomic_file.hpp"
#include "io/posterior_json.hpp"
#include "site/road_source.hpp"
#include "smc/engine.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

void SiteFlags::add_to(po::options_description& desc, bool with_sensors) {
  desc.add_options()
      ("envelopment", po::value(&envelopment_m)->value_name("LENGTH")->default_value(envelopment_m, shortest_text(envelopment_m)),
       "tyre envelopment: moving-average base length along travel (m); 0 = off");
  if (with_sensors) {
    desc.add_options()("sensors", po::value(&sensors)->value_name("FIRST,SPACING,COUNT")->default_value(sensors),
                       "the sensor array: the first sensor's position (m), the spacing (m) and the number of sensors");
  }
  desc.add_options()
      ("m1", po::value(&m1_kg)->value_name("MASS")->default_value(m1_kg), "unsprung mass m1 (kg)")
      ("cb", po::value(&cb_nspm)->value_name("DAMPING")->default_value(cb_nspm), "suspension damping c_b (N s/m)")
      ("ct", po::value(&ct_nspm)->value_name("DAMPING")->default_value(ct_nspm), "tyre damping c_t (N s/m); 0 in the paper");
}

site::SiteOptions SiteFlags::to_options() const {
  site::SiteOptions o;
  o.envelopment_m = envelopment_m;
  o.unsprung_mass_kg = m1_kg;
  o.suspension_damping_nspm = cb_nspm;
  o.tyre_damping_nspm = ct_nspm;
  std::stringstream ss(sensors);
  std::string a, b, c;
  if (!std::getline(ss, a, ',') || !std::getline(ss, b, ',') || !std::getline(ss, c) ) {
    throw UsageError("--sensors '" + sensors + "': expected FIRST_M,SPACING_M,COUNT, e.g. 76,1.5,16");
  }
  try {
    std::size_t used = 0;
    o.sensors.first_m = std::stod(a, &used);
    if (used != a.size()) throw std::invalid_argument(a);
    o.sensors.spacing_m = std::stod(b, &used);
    if (used != b.size()) throw std::invalid_argument(b);
    o.sensors.count = std::stoi(c, &used);
    if (used != c.size()) throw std::invalid_argument(c);
  } catch (const std::logic_error&) {
    throw UsageError("--sensors '" + sensors + "': expected FIRST_M,SPACING_M,COUNT, e.g. 76,1.5,16");
  }
  o.validate();
  return o;
}

std::string shortest_text(double value) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
  return std::string(buffer, end);
}

void check_particles(long particles) {
  const long most = smc::TemperedSampler::kMaxParticles;
  if (particles < 2 || particles > most) {
    throw UsageError("--particles " + std::to_string(particles) + ": must be between 2 and " + std::to_string(most));
  }
}

std::uint64_t parse_seed(const std::string& text, const std::string& option) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end) {
    throw UsageError(option + " '" + text + "' is not a whole number in [0, 2^64)");
  }
  return value;
}

void write_output(const std::string& path, const std::function<void(std::ostream&)>& write) {
  if (path.empty() || path == "-") {
    write(std::cout);
    std::cout.flush();
    if (!std::cout) throw IoError("writing to standard output failed");
    return;
  }
  io::write_file_atomically(path, write);
}

std::vector<records::WimRecord> read_site_log(const std::string& path, const site::Site& site, const SiteFlags& flags,
                                              const io::WimLimits& limits) {
  int sensors = 0;
  std::size_t header_line = 1;
  auto records = io::read_wim_log_file(path, site.options().unsprung_mass_kg, &sensors, limits, &header_line);
  if (sensors != site.sensors()) {
    throw DataError(path, header_line, "if_" + std::to_string(sensors),
                    "the log has " + std::to_string(sensors) + " sensors but the site has " +
                        std::to_string(site.sensors()) + " (--sensors " + flags.sensors + ")");
  }
  return records;
}

site::Site site_of_manifest_entry(const io::SiteManifest& manifest, const io::ManifestSite& entry, SiteFlags& flags,
                                  std::ostream* warnings) {
  const std::string who = "site '" + entry.name + "': ";
  const auto fail = [&](const std::string& key, const std::string& what) {
    throw DataError(manifest.path, 0, io::SiteManifest::field(entry, key), who + what);
  };
  flags.sensors = entry.sensors;
  site::SiteOptions options;
  try {
    options = flags.to_options();
  } catch (const UsageError& e) {
    fail("sensors", e.what());
  }
  road::Surface surface;
  try {
    surface = site::load_road(entry.road, warnings);
  } catch (const std::runtime_error& e) {  // DataError (the road file's own fault), UsageError, MissingInputError
    fail("road", e.what());
  }
  std::optional<site::Site> site;
  try {
    site.emplace(std::move(surface), options);
  } catch (const UsageError& e) {  // a sensor beyond the road's end
    fail("sensors", e.what());
  } catch (const DataError& e) {  // missing cells under the trucks' stretch
    fail("road", e.what());
  }
  const std::size_t gains = entry.calibration.size();
  if (gains != 0 && gains != static_cast<std::size_t>(site->sensors())) {
    fail("calibration", std::to_string(gains) + " gains for " + std::to_string(site->sensors()) +
                            " sensors (one gain per sensor, in sensor order)");
  }
  return std::move(*site);
}

Eigen::VectorXd manifest_sensor_gains(const io::ManifestSite& entry, int sensors) {
  if (entry.calibration.empty()) return Eigen::VectorXd::Ones(sensors);
  return Eigen::Map<const Eigen::VectorXd>(entry.calibration.data(), static_cast<Eigen::Index>(entry.calibration.size()));
}

std::vector<const site::Site*> ManifestSites::pointers() const {
  std::vector<const site::Site*> p;
  for (const auto& s : sites) p.push_back(s.get());
  return p;
}

ManifestSites build_manifest_sites(const io::SiteManifest& manifest, const SiteFlags& flags, std::ostream* warnings) {
  ManifestSites out;
  for (const io::ManifestSite& entry : manifest.sites) {
    out.flags.push_back(flags);
    out.sites.push_back(std::make_unique<site::Site>(site_of_manifest_entry(manifest, entry, out.flags.back(), warnings)));
  }
  return out;
}

void refuse_beside_sites(const po::variables_map& vm, std::initializer_list<const char*> own) {
  for (const char* key : own) {
    if (vm.count(key) && !vm[key].defaulted()) {
      throw UsageError(std::string("--") + key + " with --sites: a manifest's site brings its own road, sensors and log");
    }
  }
}

std::vector<records::WimRecord> read_manifest_site_log(const io::SiteManifest& manifest, const io::ManifestSite& entry,
                                                       const site::Site& site, const SiteFlags& flags,
                                                       const io::WimLimits& limits) {
  if (entry.log.empty()) {
    throw DataError(manifest.path, 0, io::SiteManifest::field(entry, "log"),
                    "site '" + entry.name + "': missing: a fit reads each site's log (only a stream's manifest, whose "
                    "one input names each record's site, may leave it out)");
  }
  try {
    std::vector<records::WimRecord> records = read_site_log(entry.log, site, flags, limits);
    if (!entry.calibration.empty()) {
      const Eigen::VectorXd gains = manifest_sensor_gains(entry, site.sensors());
      for (auto& r : records) fleet::remove_sensor_gains(r, gains);
    }
    return records;
  } catch (const DataError& e) {
    throw DataError(e.file(), e.line(), e.field(),
                    "site '" + entry.name + "' of manifest '" + manifest.path + "': " + e.reason());
  }
}

// "76,77.5,80" or "FIRST:STEP:LAST" (inclusive, e.g. 76:0.05:98.5).
std::vector<double> parse_positions(const std::string& text) {
  std::vector<double> p;
  if (text.empty()) return p;
  const auto number = [&](const std::string& s) {
    try {
      std::size_t used = 0;
      const double v = std::stod(s, &used);
      if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);  // stod takes "nan", "inf"
      return v;
    } catch (const std::logic_error&) {
      throw UsageError("--positions '" + text + "': '" + s + "' is not a finite number");
    }
  };
  if (text.find(':') != std::string::npos) {
    std::stringstream ss(text);
    std::string a, b, c;
    if (!std::getline(ss, a, ':') || !std::getline(ss, b, ':') || !std::getline(ss, c)) {
      throw UsageError("--positions '" + text + "': expected FIRST:STEP:LAST");
    }
    const double first = number(a), step = number(b), last = number(c);
    if (!(step > 0.0) || last < first) throw UsageError("--positions '" + text + "': need STEP > 0 and LAST >= FIRST");
    // The count is checked as a double: 13:0.05:7e54 is 1.5e56 positions, past a long (casting it was
    // undefined behaviour, found by fuzz/site_options_fuzzer).
    const double count = std::floor((last - first) / step + 1e-9) + 1.0;
    if (!(count <= 1e6)) throw UsageError("--positions '" + text + "': more than a million positions");
    const auto n = static_cast<long>(count);
    for (long i = 0; i < n; ++i) p.push_back(first + static_cast<double>(i) * step);
    return p;
  }
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) p.push_back(number(item));
  for (std::size_t i = 1; i < p.size(); ++i) {
    if (!(p[i] > p[i - 1])) throw UsageError("--positions '" + text + "': positions must be strictly increasing");
  }
  return p;
}

void SiteChoice::add_to(po::options_description& desc) {
  desc.add_options()
      ("sites", po::value(&manifest_path)->value_name("MANIFEST"),
       "a site manifest; with --site, at that site (its road and sensors from the manifest, in place of --road and "
       "--sensors)")
      ("site", po::value(&site_name)->value_name("NAME"),
       "the manifest's site: a posterior of several sites (fit --sites) then gives that site's own traffic");
}

site::Site SiteChoice::site(const std::string& road, const po::variables_map& vm, SiteFlags& flags) const {
  if (manifest_path.empty() != site_name.empty()) {
    throw UsageError(site_name.empty() ? "--sites needs --site NAME: the site to use"
                                       : "--site names a site of a manifest: give the manifest with --sites");
  }
  if (manifest_path.empty()) return site::Site(site::load_road(road, &std::cerr), flags.to_options());
  refuse_beside_sites(vm, {"road", "sensors"});
  const io::SiteManifest manifest = io::read_site_manifest(manifest_path);
  return site_of_manifest_entry(manifest, manifest.find(site_name), flags, &std::cerr);
}

void require_fitted_site(const fleet::PosteriorCloud& cloud, const std::string& posterior_path, const site::Site& site,
                         const std::string& hint) {
  if (cloud.site_fingerprint == site.fingerprint()) return;
  if (!cloud.sites.empty()) {
    throw UsageError("the posterior in '" + posterior_path + "' was fitted on several sites (roads '" + cloud.road_name +
                     "'): use one with --sites MANIFEST --site NAME" +
                     (hint.find("--new-road") != std::string::npos ? ", or another road with --new-road" : ""));
  }
  throw UsageError("the posterior in '" + posterior_path + "' was fitted on another site (road '" + cloud.road_name +
                   "', fingerprint " + cloud.site_fingerprint + ") than road '" + site.surface().name +
                   "' with these site options (fingerprint " + site.fingerprint() + ")" + hint);
}

ClassSelection select_posterior_classes(const std::string& source, const std::string& class_label,
                                        const std::string& mix_text, const std::string& site_name) {
  if (!class_label.empty() && !mix_text.empty()) throw UsageError("give --class or --mix, not both");
  fleet::ClassPosteriors classes = io::read_posterior_classes(source);
  if (fleet::unlabelled(classes) && (!class_label.empty() || !mix_text.empty())) {
    throw UsageError(std::string(class_label.empty() ? "--mix" : "--class") + ": the posterior in '" + source +
                     "' has no vehicle classes (its log had no class column)");
  }
  if (!class_label.empty()) classes = fleet::select_class(classes, class_label);
  // A posterior of several sites seen from one: each class's own traffic there, and (unless --mix
  // says otherwise) the classes' shares of that site's trucks; a site with no trucks yet (a young
  // stream) keeps every site's.
  const fleet::ClassPosteriors whole = classes;
  long at_site = 0;
  if (!site_name.empty()) {
    for (auto& c : classes) {
      if (c.cloud.sites.empty()) continue;
      c.cloud = fleet::cloud_at_site(c.cloud, fleet::find_cloud_site(c.cloud, site_name, source));
      at_site += c.cloud.trucks_seen;
    }
  }
  std::vector<double> shares =
      fleet::class_shares(at_site > 0 || site_name.empty() ? classes : whole, fleet::parse_mix(mix_text));
  return {std::move(classes), std::move(shares)};
}

}  // namespace ssrfleet::cli
