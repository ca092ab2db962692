#include "io/site_manifest.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "io/atomic_file.hpp"
#include "records/vehicle_class.hpp"
#include "road/surface_presets.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace fs = std::filesystem;

namespace {
constexpr const char* kSiteKeys[] = {"name", "road", "sensors", "log", "calibration"};

std::string resolve(const std::string& folder, const std::string& path) {
  const fs::path p(path);
  return p.is_absolute() || folder.empty() ? path : (fs::path(folder) / p).lexically_normal().string();
}

std::string key_list() {
  std::string s;
  for (const char* k : kSiteKeys) s += std::string(s.empty() ? "" : ", ") + k;
  return s;
}
}  // namespace

std::string SiteManifest::field(const ManifestSite& site, const std::string& key) {
  return "sites[" + std::to_string(site.index) + "]." + key;
}

const ManifestSite& SiteManifest::find(const std::string& name) const {
  std::string names;
  for (const auto& s : sites) {
    if (s.name == name) return s;
    names += (names.empty() ? "" : ", ") + s.name;
  }
  throw UsageError("--site '" + name + "': the manifest '" + path + "' has no such site (it has " + names + ")");
}

SiteManifest read_site_manifest(std::istream& in, const std::string& path, const std::string& folder) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw DataError(path, 0, "json", std::string("not valid JSON (") + e.what() + ")");
  }
  if (!j.is_object()) throw DataError(path, 0, "json", "must be an object {\"sites\": [...]}");
  for (const auto& [key, value] : j.items()) {
    if (key != "sites") throw DataError(path, 0, key, "unknown key (a manifest has one key, \"sites\")");
  }
  if (!j.contains("sites")) throw DataError(path, 0, "sites", "missing");
  const auto& list = j["sites"];
  if (!list.is_array() || list.empty()) throw DataError(path, 0, "sites", "must be a non-empty array of sites");

  SiteManifest m;
  m.path = path;
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    ManifestSite s;
    s.index = i;
    const std::string at = "sites[" + std::to_string(i) + "]";
    const auto& e = list[i];
    if (!e.is_object()) throw DataError(path, 0, at, "must be an object with " + key_list());
    // The name first, so every later message can name the site.
    const auto text = [&](const char* key) -> std::string {
      const std::string who = s.name.empty() ? "" : "site '" + s.name + "': ";
      if (!e.contains(key)) throw DataError(path, 0, at + "." + key, who + "missing (a site has " + key_list() + ")");
      if (!e[key].is_string() || e[key].get<std::string>().empty()) {
        throw DataError(path, 0, at + "." + key, who + "must be a non-empty string");
      }
      return e[key].get<std::string>();
    };
    s.name = text("name");
    if (!records::is_class_label(s.name)) {
      throw DataError(path, 0, at + ".name", "'" + s.name + "' is not a site name (one or more of A-Z a-z 0-9 _ . -)");
    }
    if (!names.insert(s.name).second) throw DataError(path, 0, at + ".name", "site '" + s.name + "' appears twice");
    for (const auto& [key, value] : e.items()) {
      if (std::find(std::begin(kSiteKeys), std::end(kSiteKeys), key) == std::end(kSiteKeys)) {
        throw DataError(path, 0, at + "." + key, "site '" + s.name + "': unknown key (a site has " + key_list() + ")");
      }
    }
    const std::string road = text("road");
    s.road = road::is_preset_name(road) ? road : resolve(folder, road);
    if (!road::is_preset_name(road) && !fs::is_regular_file(s.road)) {
      throw DataError(path, 0, at + ".road",
                      "site '" + s.name + "': no road file '" + s.road + "' (a preset AS1, AS2, AS3 or a road file, "
                      "relative to the manifest's folder)");
    }
    s.sensors = text("sensors");
    // A stream's manifest may leave the logs out: the stream reads one input, its `site` column
    // naming each record's site. A fit reads each site's log (read_manifest_site_log asks for it).
    if (e.contains("log")) s.log = resolve(folder, text("log"));
    if (!s.log.empty() && !fs::is_regular_file(s.log)) {
      throw DataError(path, 0, at + ".log",
                      "site '" + s.name + "': no log file '" + s.log + "' (paths are relative to the manifest's folder)");
    }
    if (e.contains("calibration")) {
      const auto& gains = e["calibration"];
      const std::string where = at + ".calibration";
      if (!gains.is_array() || gains.empty()) {
        throw DataError(path, 0, where, "site '" + s.name + "': must be an array of gains, one per sensor");
      }
      for (std::size_t k = 0; k < gains.size(); ++k) {
        const double g = gains[k].is_number() ? gains[k].get<double>() : std::nan("");
        if (!(g >= kMinCalibrationGain && g <= kMaxCalibrationGain)) {
          throw DataError(path, 0, where + "[" + std::to_string(k) + "]",
                          "site '" + s.name + "': must be a number in [0.5, 2] (sensor " + std::to_string(k + 1) +
                              "'s gain: it reports gain x the true impact factor)");
        }
        s.calibration.push_back(g);
      }
    }
    m.sites.push_back(std::move(s));
  }
  return m;
}

void write_site_manifest(const std::string& path, const SiteManifest& manifest) {
  nlohmann::json sites = nlohmann::json::array();
  for (const ManifestSite& s : manifest.sites) {
    nlohmann::json e = {{"name", s.name}, {"road", s.road}, {"sensors", s.sensors}};
    if (!s.log.empty()) e["log"] = s.log;
    if (!s.calibration.empty()) e["calibration"] = s.calibration;
    sites.push_back(std::move(e));
  }
  write_file_atomically(path, [&](std::ostream& os) { os << nlohmann::json{{"sites", sites}}.dump(1) << "\n"; });
}

SiteManifest read_site_manifest(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw MissingInputError("cannot open site manifest '" + path + "'");
  // The JSON is parsed whole, into a tree several times its size: a file far past any network's
  // manifest (a site is about 100 bytes) is refused before a byte is parsed (docs/site-data.md).
  std::error_code ec;
  const auto bytes = fs::file_size(path, ec);
  if (!ec && bytes > kMaxSiteManifestBytes) {
    throw DataError(path, 0, "size",
                    std::to_string(bytes) + " bytes, more than a site manifest may hold (" +
                        std::to_string(kMaxSiteManifestBytes) + ")");
  }
  return read_site_manifest(in, path, fs::path(path).parent_path().string());
}

}  // namespace ssrfleet::io
