// The site manifest: the WIM sites of one road network, each with its road surface,
// its sensor array and its log, in one JSON file:
//   {"sites": [{"name": "A12-north", "road": "a12n.crg", "sensors": "76,1.5,16", "log": "a12n.csv"},
//              ...]}
// A site may also give "calibration": one gain per sensor, in sensor order, each in [0.5, 2]: that
// sensor reports gain x the true impact factor (a WIM operator's calibration factors), and a fit or
// stream divides it out of every record of the site before the fleet sees it.
// Paths are relative to the manifest's folder (absolute ones are kept); a road may also be a
// preset name (AS1, AS2, AS3). The vehicle constants (m1, c_b, c_t, envelopment) belong to the
// fleet, not to a site, so they stay command-line options shared by every site.
//
// This file only reads and checks the format: every key known, every field of the right kind, names
// unique, files present (a site's log may be left out: `stream --sites` reads one input with a
// `site` column; fit asks for each site's log). Building a site from an entry (its road must cover its sensors) is
// site_of_manifest_entry's job (bin/cli_common.hpp), which names the manifest, site and field too.
#pragma once

#include <cstdint>
#include <istream>
#include <string>
#include <vector>

namespace ssrfleet::io {

struct ManifestSite {
  std::string name;     // unique in the manifest: one or more of A-Z a-z 0-9 _ . -
  std::string road;     // a preset name, or the road file's path resolved against the manifest's folder
  std::string sensors;  // FIRST_M,SPACING_M,COUNT, as --sensors reads it
  std::string log;      // the WIM log's path, resolved against the manifest's folder; "" if not given
                        // (a stream's manifest: its one input names each record's site)
  std::vector<double> calibration;  // one gain per sensor (empty: every gain 1); the count is checked
                                    // against the sensors where the site is built
  std::size_t index = 0;  // its place in the manifest (fields are named "sites[index].key")
};

struct SiteManifest {
  std::string path;  // the manifest file, for messages
  std::vector<ManifestSite> sites;

  // The site called `name`; a UsageError listing the manifest's names when there is none.
  const ManifestSite& find(const std::string& name) const;
  // "sites[i].key" for a field of site i, as every message names it.
  static std::string field(const ManifestSite& site, const std::string& key);
};

// A known calibration gain is a factor on a sensor's reading: outside [0.5, 2] it is a wrong file,
// not a sensor.
inline constexpr double kMinCalibrationGain = 0.5;
inline constexpr double kMaxCalibrationGain = 2.0;

// The largest manifest file read: 16 MiB, some 150,000 sites.
inline constexpr std::uintmax_t kMaxSiteManifestBytes = 16u << 20;

// Writes a manifest that read_site_manifest reads back to the same sites (each path as it is in
// `manifest`: make them absolute first if the file goes to another folder), atomically.
void write_site_manifest(const std::string& path, const SiteManifest& manifest);

// Reads and checks a manifest. Any problem is a DataError naming the manifest, the field
// ("sites[2].log") and, where one is known, the site ("site 'B': no file ..."); a missing manifest
// is a MissingInputError.
SiteManifest read_site_manifest(const std::string& path);
// The same from a stream: `path` names it in messages, `folder` resolves relative paths.
SiteManifest read_site_manifest(std::istream& in, const std::string& path, const std::string& folder);

}  // namespace ssrfleet::io
