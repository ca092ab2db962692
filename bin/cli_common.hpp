// Pieces every subcommand shares: option groups for the site, parsing helpers, output helpers.
#pragma once

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <iosfwd>
#include <string>
#include <vector>

#include <boost/program_options.hpp>

#include "fleet/posterior_cloud.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/site_manifest.hpp"
#include "io/wim_log.hpp"
#include "site/site.hpp"

namespace ssrfleet::cli {

namespace po = boost::program_options;

// --help's words for the options every command shares.
inline constexpr const char* kRoadHelp =
    "the road: preset AS1, AS2 or AS3, or a road file (a road CSV or an OpenCRG .crg surface; the kind is read from "
    "the file's content)";
inline constexpr const char* kPosteriorHelp =
    "the posterior: a file that fit writes (or diagnose --posterior-out), or a stream's state directory (its "
    "posterior.json)";

// Options that define a site: --envelopment, --sensors, --m1, --cb, --ct.
struct SiteFlags {
  double envelopment_m = 0.3;
  std::string sensors = "76,1.5,16";
  double m1_kg = 420.0;
  double cb_nspm = 20e3;
  double ct_nspm = 0.0;

  // with_sensors = false: the vehicle constants only (a manifest's sites bring their own sensors).
  void add_to(po::options_description& desc, bool with_sensors = true);
  site::SiteOptions to_options() const;  // UsageError on a malformed --sensors
};

// Parses argv (argv[0] the command's name) with desc (and positional names), turning
// program_options errors into UsageError. Returns false if --help was given, after printing the
// command's help to stdout (help_format.hpp): `usage` holds the synopses, one a line, each
// starting "ssrfleet COMMAND"; the command's summary (command_table.hpp) and then `about`, if
// any, come before the options.
bool parse_or_help(int argc, const char* const argv[], const po::options_description& desc,
                   const po::positional_options_description* positional, po::variables_map& vm,
                   const std::string& usage, const std::string& about = "");

// An option that a command does not take although users may expect it to (another command's, or
// an earlier spelling): given anyway, it is a UsageError that names what to give instead, rather
// than program_options' "unrecognised option" or, worse, its guess of a longer option that the
// name begins (--posterior for --posterior-out).
struct RefusedOption {
  std::string name;     // "--state"
  std::string instead;  // "give the state directory with --posterior DIR"
};
void refuse_options(int argc, const char* const argv[], const std::vector<RefusedOption>& refused);

// A number as --help should show its default: the shortest text that reads back to it ("0.3",
// where program_options' own conversion prints "0.29999999999999999").
std::string shortest_text(double value);

// --particles P: UsageError unless 2 <= P <= smc::TemperedSampler::kMaxParticles (1e7),
// checked before the road is built so that an absurd count fails at once (docs/site-data.md).
void check_particles(long particles);

// Parses a seed: a whole number in [0, 2^64). Anything else is a UsageError naming the option.
std::uint64_t parse_seed(const std::string& text, const std::string& option = "--seed");

// Reads a whole WIM log for `site`: DataError (line 1, the first IF column) when its sensor
// count is not the site's, naming the --sensors value in use.
// limits: what a record may hold (e.g. fhwa_classes).
std::vector<records::WimRecord> read_site_log(const std::string& path, const site::Site& site, const SiteFlags& flags,
                                              const io::WimLimits& limits = {});

// A site of a manifest (io/site_manifest.hpp): its road and --sensors from the entry, the vehicle
// constants from `flags` (they belong to the fleet). Any problem with the entry (a road that cannot
// be read, a malformed sensor array, a road that does not cover its sensors) is a DataError naming
// the manifest, the field ("sites[1].sensors") and the site. `flags` comes back with the entry's
// sensors in it (for read_manifest_site_log).
site::Site site_of_manifest_entry(const io::SiteManifest& manifest, const io::ManifestSite& entry, SiteFlags& flags,
                                  std::ostream* warnings);
// The gains of a manifest site's sensors (its "calibration"; every gain 1 without one), `sensors`
// long (site_of_manifest_entry has checked the count).
Eigen::VectorXd manifest_sensor_gains(const io::ManifestSite& entry, int sensors);
// read_site_log for a manifest's site: the same errors (file, line, field), each reason starting
// with the site and the manifest. A site's calibration is divided out of every record.
std::vector<records::WimRecord> read_manifest_site_log(const io::SiteManifest& manifest, const io::ManifestSite& entry,
                                                       const site::Site& site, const SiteFlags& flags,
                                                       const io::WimLimits& limits = {});

// A manifest's sites, each built by site_of_manifest_entry with the flags it comes back with (its
// sensors, for read_manifest_site_log). On the heap: fits and streams keep pointers to them.
struct ManifestSites {
  std::vector<std::unique_ptr<site::Site>> sites;
  std::vector<SiteFlags> flags;
  std::vector<const site::Site*> pointers() const;
};
ManifestSites build_manifest_sites(const io::SiteManifest& manifest, const SiteFlags& flags, std::ostream* warnings);

// UsageError for any of `own` given on the command line beside --sites (a manifest's site brings
// its own road, sensors, log).
void refuse_beside_sites(const po::variables_map& vm, std::initializer_list<const char*> own);

// Positions along the road: "76,77.5,80" or "FIRST:STEP:LAST" (inclusive, e.g. 76:0.05:98.5);
// "" = none (the caller's default). UsageError naming --positions when malformed.
std::vector<double> parse_positions(const std::string& text);

// Where a posterior is applied (predict, damage, weigh): a site of a manifest (--sites M --site NAME:
// its road and sensors from the manifest) or --road with the site flags.
struct SiteChoice {
  std::string manifest_path, site_name;
  void add_to(po::options_description& desc);
  // UsageError for --sites without --site or the other way round, or --road / --sensors beside them.
  site::Site site(const std::string& road, const po::variables_map& vm, SiteFlags& flags) const;
};

// UsageError unless the posterior was fitted on `site` (same fingerprint); `hint` ends the message.
void require_fitted_site(const fleet::PosteriorCloud& cloud, const std::string& posterior_path, const site::Site& site,
                         const std::string& hint);

// Writes through `write` to `path` atomically, or to stdout when path is "-" or empty.
void write_output(const std::string& path, const std::function<void(std::ostream&)>& write);

// The posterior's classes that --class / --mix ask for (predict, damage), read from `source` (a
// posterior file or a state directory), and their shares. UsageError for both options at once or
// either on a posterior without classes.
struct ClassSelection {
  fleet::ClassPosteriors classes;
  std::vector<double> shares;
};
// site_name: a site of a posterior of several sites (fit --sites): each class narrowed to it
// (fleet::cloud_at_site) and the observed shares those of its trucks; a posterior of one site is
// left as it is (its site is checked against the road by the caller).
ClassSelection select_posterior_classes(const std::string& source, const std::string& class_label,
                                        const std::string& mix_text, const std::string& site_name = "");

}  // namespace ssrfleet::cli
