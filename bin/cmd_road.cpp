// ssrfleet road: describe a road (preset, road CSV, OpenCRG surface or ERD profiles): size,
// spacing, missing cells, RMS height, fitted G_d(n0) and waviness w with its roughness class, the
// IRI of the wheel paths and across the width; and convert it: a surface to a road CSV or an
// OpenCRG file (--write), the wheel paths' profiles to an ERD file (--erd).
// A road with missing cells is described, never refused: the summary says where the holes are and
// gives an IRI across one as unavailable. Only a conversion that would have to invent heights is
// refused, before anything is written: a road CSV and an ERD file have no marker for a missing
// height, so any number written in its place would be read back as road.
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "road/crg_reader.hpp"
#include "road/crg_writer.hpp"
#include "road/erd_format.hpp"
#include "road/road_format.hpp"
#include "road/surface_csv.hpp"
#include "road/surface_presets.hpp"
#include "road/missing_cells.hpp"
#include "road/surface_summary.hpp"
#include "road/wheel_path.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {

std::vector<double> parse_wheel_path_positions(const std::string& text) {
  std::vector<double> zs;
  std::stringstream in(text);
  std::string cell;
  while (std::getline(in, cell, ',')) {
    std::size_t used = 0;
    double z = 0.0;
    try {
      z = std::stod(cell, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != cell.size()) throw UsageError("--wheel-paths: '" + cell + "' is not a lateral position (m)");
    zs.push_back(z);
  }
  if (zs.empty()) throw UsageError("--wheel-paths needs at least one lateral position (m)");
  return zs;
}

bool ends_with_crg(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".crg";
}

// The surface as simulate would read it, with the reader's warnings on stderr; an OpenCRG file's
// missing cells are left to the summary, which maps them (for `road` they are not refused).
road::Surface load_for_inspection(const std::string& spec) {
  if (road::is_preset_name(spec) || road::detect_road_format(spec) != road::RoadFileFormat::crg) {
    return site::load_road(spec, &std::cerr);
  }
  road::CrgRoad crg = road::read_crg_file(spec);
  for (const std::string& w : crg.report.warnings) std::cerr << "warning: road '" << spec << "': " << w << "\n";
  return std::move(crg.surface);
}

std::string clear_lines_text(const road::SurfaceSummary& summary) {
  if (summary.missing.clear_lines.empty()) return "no lateral line is clear of holes";
  std::ostringstream os;
  os << "positions clear of holes: y = ";
  for (std::size_t k = 0; k < summary.missing.clear_lines.size() && k < 6; ++k) {
    const auto [first, last] = summary.missing.clear_lines[k];
    os << (k == 0 ? "" : ", ") << summary.y0_m + summary.dy_m * static_cast<double>(first);
    if (last > first) os << " .. " << summary.y0_m + summary.dy_m * static_cast<double>(last);
  }
  os << " m";
  return os.str();
}

// Refuses, before anything is written, an output that cannot hold the surface's holes.
void check_outputs_hold_holes(const road::Surface& surface, const road::SurfaceSummary& summary,
                              const std::string& write_path, const std::string& erd_path,
                              const std::vector<double>& erd_paths_m) {
  if (summary.missing_cells == 0) return;
  if (!write_path.empty() && !ends_with_crg(write_path)) {
    throw DataError(surface.name, 0, "--write " + write_path,
                    "the road has " + road::describe_span(road::find_missing(surface), surface) +
                        "; a road CSV has no marker for a missing height, so the surface is not written: write "
                        "an OpenCRG file (.crg), which keeps them as missing");
  }
  if (erd_path.empty()) return;
  for (const double z : erd_paths_m) {
    const road::MissingCells missing = road::missing_on_path(surface, z);
    if (missing.count == 0) continue;
    std::ostringstream where;
    where << "--erd wheel path z = " << z << " m";
    throw DataError(surface.name, 0, where.str(),
                    "crosses " + road::describe_span(missing, surface) +
                        "; an ERD file has no marker for a missing height, so the profiles are not written to '" +
                        erd_path + "': choose --wheel-paths on measured road (" + clear_lines_text(summary) + ")");
  }
}

void print(const road::SurfaceSummary& summary, bool json) {
  if (json) {
    std::cout << road::to_json(summary).dump(2) << "\n";
    return;
  }
  const std::string text = road::to_text(summary);
  std::cout << text << (text.empty() || text.back() != '\n' ? "\n" : "");
}

}  // namespace

int run_road(int argc, const char* const argv[]) {
  std::string spec, write_path, erd_path, wheel_paths_text, crg_format_text = "KDBI", classes = "iso8608";
  bool json = false;
  double iri_step_m = 0.5;
  po::options_description desc("road options");
  desc.add_options()
      ("help,h", "show this help")
      ("road", po::value(&spec)->value_name("ROAD")->required(),
       "preset AS1, AS2 or AS3, a road CSV, an OpenCRG (.crg) surface or an ERD profile file (positional: ROAD)")
      ("write,w", po::value(&write_path)->value_name("FILE"),
       "write the surface to this file: OpenCRG if it ends in .crg, else a road CSV")
      ("crg-format", po::value(&crg_format_text)->value_name("TYPE")->default_value(crg_format_text),
       "OpenCRG data type for --write: KDBI (binary double, exact), KRBI, LDFI or LRFI")
      ("erd", po::value(&erd_path)->value_name("FILE"), "write the wheel paths' longitudinal profiles to this ERD file")
      ("wheel-paths", po::value(&wheel_paths_text)->value_name("Z,Z,..."),
       "lateral positions (m) of the wheel paths, comma-separated (default: the surface's centre -/+ 0.9 m, or its "
       "centre alone on a surface narrower than 1.8 m)")
      ("classes", po::value(&classes)->value_name("TABLE")->default_value(classes),
       "roughness class table: iso8608 (ISO 8608:1995) or paper (the ISO draft of 1982 the paper's labels follow)")
      ("json", po::bool_switch(&json), "print the summary as JSON instead of text")
      ("iri-step", po::value(&iri_step_m)->value_name("DZ")->default_value(iri_step_m),
       "lateral spacing of the IRI positions (m)");
  po::positional_options_description positional;
  positional.add("road", 1);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, &positional, vm,
                     "ssrfleet road ROAD [--write FILE] [--erd FILE] [--wheel-paths Z,Z,...] [--json]",
                     "The summary (size, spacing, missing cells, RMS height, the fitted roughness and its class, the "
                     "IRI of the wheel paths and across the width) goes to standard output.")) {
    return 0;
  }
  if (!(iri_step_m > 0.0)) throw UsageError("--iri-step must be positive");
  road::CrgDataFormat crg_format{};
  if (!road::parse_crg_format(crg_format_text, crg_format)) {
    throw UsageError("--crg-format: '" + crg_format_text + "' is not one of KDBI, KRBI, LDFI, LRFI");
  }
  road::SummaryOptions options;
  options.iri_step_m = iri_step_m;
  try {
    options.table = road::parse_roughness_table(classes);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--classes: ") + e.what());
  }
  if (vm.count("wheel-paths")) options.wheel_paths_m = parse_wheel_path_positions(wheel_paths_text);

  if (!road::is_preset_name(spec) && road::detect_road_format(spec) == road::RoadFileFormat::erd) {
    // Longitudinal profiles: each one a wheel path; there is no surface to write or to sample.
    if (!write_path.empty()) throw UsageError("--write needs a surface; '" + spec + "' holds profiles (ERD)");
    if (!options.wheel_paths_m.empty()) throw UsageError("--wheel-paths needs a surface; in '" + spec + "' each profile is one");
    const road::LongitudinalProfiles profiles = road::read_erd_file(spec);
    if (!erd_path.empty()) road::write_erd_file(profiles, erd_path);
    print(road::summarize(profiles, options.table), json);
    return 0;
  }
  const road::Surface surface = load_for_inspection(spec);
  const road::SurfaceSummary summary = road::summarize(surface, options);
  const std::vector<double> zs = options.wheel_paths_m.empty() ? road::default_wheel_paths_m(surface) : options.wheel_paths_m;
  check_outputs_hold_holes(surface, summary, write_path, erd_path, zs);
  if (!write_path.empty()) {
    if (ends_with_crg(write_path)) road::write_crg_file(surface, write_path, crg_format);
    else road::write_surface_csv_file(surface, write_path);
  }
  if (!erd_path.empty()) road::write_erd_file(road::wheel_path_profiles(surface, zs), erd_path);
  print(summary, json);
  return 0;
}

}  // namespace ssrfleet::cli
