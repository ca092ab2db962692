// `ssrfleet sites M --check`: which site's fleet differs from the others'
// (discrepancy/site_conflicts.hpp). Fits each site alone and every other site without it.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>

#include "cli_common.hpp"
#include "io/site_manifest.hpp"

namespace ssrfleet::cli {

struct SiteCheckFlags {
  long particles = 1024;
  int threads = 0;  // 0 = all cores
  std::uint64_t seed = 1;
  double alpha = 0.01;
};

// The table (CSV: one row per site) of the check; each flagged site named on `messages`, or a line
// saying none is. progress: a line per fit (nullptr = quiet).
std::string check_site_fleets(const io::SiteManifest& manifest, const SiteFlags& flags, const SiteCheckFlags& check,
                              std::ostream* progress, std::ostream& messages);

}  // namespace ssrfleet::cli
