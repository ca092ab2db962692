#include "sites_check.hpp"

#include <iomanip>
#include <sstream>

#include "discrepancy/site_conflicts.hpp"
#include "model/fleet_model.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

std::string check_site_fleets(const io::SiteManifest& manifest, const SiteFlags& flags, const SiteCheckFlags& check,
                              std::ostream* progress, std::ostream& messages) {
  check_particles(check.particles);
  if (manifest.sites.size() < 2) {
    throw UsageError("--check compares each site with the others: the manifest '" + manifest.path + "' has one site");
  }
  const ManifestSites sites = build_manifest_sites(manifest, flags, progress);
  std::vector<std::vector<records::WimRecord>> logs;
  for (std::size_t s = 0; s < manifest.sites.size(); ++s) {
    logs.push_back(read_manifest_site_log(manifest, manifest.sites[s], *sites.sites[s], sites.flags[s]));
  }
  discrepancy::SiteConflictOptions o;
  o.fit.marginal.sampler.particles = check.particles;
  o.fit.marginal.sampler.threads = check.threads > 0 ? check.threads : smc::TemperedSampler::Options::default_threads();
  o.fit.marginal.sampler.seed = check.seed;
  o.alpha = check.alpha;
  if (progress) o.progress = [&](const std::string& line) { *progress << "ssrfleet sites --check: " << line << "\n"; };
  const auto conflicts = discrepancy::check_site_conflicts(sites.pointers(), logs, o);

  std::ostringstream out;
  out << std::setprecision(6) << "site,trucks,round,distance2,p_value,flagged";
  for (const char* h : {"K", "sigma_k", "Kt", "sigma_kt", "Z", "sigma_z", "sigma_if"}) {
    out << "," << h << "_alone," << h << "_alone_sd," << h << "_others," << h << "_others_sd";
  }
  out << "\n";
  bool any = false;
  const double threshold = check.alpha / static_cast<double>(conflicts.size());
  for (const auto& c : conflicts) {
    const std::string& name = manifest.sites[c.site].name;
    out << name << "," << c.trucks << "," << c.round << "," << c.distance2 << "," << c.p_value << ","
        << (c.flagged ? "yes" : c.undecided ? "undecided" : "no");
    for (std::size_t h = 0; h < c.alone_mean.size(); ++h) {
      out << "," << c.alone_mean[h] << "," << c.alone_sd[h] << "," << c.rest_mean[h] << "," << c.rest_sd[h];
    }
    out << "\n";
    if (c.flagged) {
      any = true;
      messages << "ssrfleet sites: site '" << name << "' is flagged: its fleet differs from the other sites' (K "
               << c.alone_mean[0] << " against " << c.rest_mean[0] << ", K_t " << c.alone_mean[2] << " against "
               << c.rest_mean[2] << "; D2 = " << c.distance2 << " on 4 degrees of freedom, p = " << c.p_value
               << " < " << threshold << ")\n";
    }
  }
  std::string undecided;
  for (const auto& c : conflicts) {
    if (c.undecided) undecided += (undecided.empty() ? "'" : " and '") + manifest.sites[c.site].name + "'";
  }
  if (!undecided.empty()) {
    messages << "ssrfleet sites: sites " << undecided << " conflict (p < " << threshold
             << "), but two sites cannot say which of them differs: add a third site of the same fleet\n";
  } else if (!any) {
    messages << "ssrfleet sites: no site's fleet differs from the others' (every p >= " << threshold << ")\n";
  }
  return out.str();
}

}  // namespace ssrfleet::cli
