// ssrfleet road: write a preset surface as a road CSV, or summarise a surface (preset or file):
// size, spacing, RMS height, fitted G_d(n0) and waviness w, and the IRI across the width.
#include <iostream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "road/surface_csv.hpp"
#include "road/surface_summary.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

int run_road(int argc, const char* const argv[]) {
  std::string spec, write_path;
  bool json = false;
  double iri_step_m = 0.5;
  po::options_description desc("road options");
  desc.add_options()
      ("help,h", "show this help")
      ("road", po::value(&spec)->required(), "preset AS1|AS2|AS3 or a road CSV file (positional)")
      ("write,w", po::value(&write_path), "write the surface as a road CSV to this file")
      ("json", po::bool_switch(&json), "print the summary as JSON instead of text")
      ("iri-step", po::value(&iri_step_m)->default_value(iri_step_m), "lateral spacing of the IRI wheel paths (m)");
  po::positional_options_description positional;
  positional.add("road", 1);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, &positional, vm, "usage: ssrfleet road AS1|AS2|AS3|FILE [--write FILE] [--json]")) {
    return 0;
  }
  if (!(iri_step_m > 0.0)) throw UsageError("--iri-step must be positive");
  const road::Surface surface = site::load_road(spec);
  if (!write_path.empty()) road::write_surface_csv_file(surface, write_path);
  const road::SurfaceSummary summary = road::summarize(surface, iri_step_m);
  if (json) std::cout << road::to_json(summary).dump(2) << "\n";
  else {
    const std::string text = road::to_text(summary);
    std::cout << text << (text.empty() || text.back() != '\n' ? "\n" : "");
  }
  return 0;
}

}  // namespace ssrfleet::cli
