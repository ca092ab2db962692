#include "fit_sites.hpp"

#include <chrono>
#include <iomanip>
#include <iostream>

#include "fleet/joint_sites.hpp"
#include "io/site_manifest.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

void fit_manifest_sites(const JointFitRequest& request, const FitFlags& fit, const SiteFlags& site_flags,
                        const io::WimLimits& limits) {
  if (request.method != "smc") {
    throw UsageError("--sites without --site fits every site at once on the SMC's marginal core; the batch MCMC "
                     "(--method mcmc) fits one site: add --site NAME");
  }
  if (fit.model != "base") {
    throw UsageError("--model " + fit.model + " with --sites: a fit of several sites fits the base model (effects "
                     "need the latent core, which fits one site); fit a site alone with --site NAME");
  }
  const io::SiteManifest manifest = io::read_site_manifest(request.manifest_path);
  std::ostream* progress = request.quiet ? nullptr : &std::cerr;
  const ManifestSites sites = build_manifest_sites(manifest, site_flags, &std::cerr);
  const std::vector<const site::Site*> site_ptrs = sites.pointers();
  std::vector<std::vector<records::WimRecord>> per_site;
  for (std::size_t s = 0; s < manifest.sites.size(); ++s) {
    const io::ManifestSite& entry = manifest.sites[s];
    per_site.push_back(read_manifest_site_log(manifest, entry, *site_ptrs[s], sites.flags[s], limits));
    // Ids are per site (the same id at two sites is two trucks): kept as SITE:ID, as a stream does.
    for (auto& r : per_site.back()) r.truck_id = entry.name + ":" + r.truck_id;
    if (progress) {
      *progress << "ssrfleet fit: site " << entry.name << ": " << per_site.back().size() << " trucks from "
                << entry.log << ", road " << site_ptrs[s]->surface().name << ", " << site_ptrs[s]->sensors()
                << " sensors\n";
    }
  }
  const std::vector<records::WimRecord> records = fleet::merge_site_records(std::move(per_site));
  if (progress) {
    *progress << "ssrfleet fit: " << records.size() << " trucks from " << manifest.sites.size()
              << " sites of manifest " << manifest.path << ", one fleet, method smc (marginal core), seed "
              << request.seed << "\n";
  }
  const auto start = std::chrono::steady_clock::now();
  fit_classes_to_file(records, request.seed, request.out, progress,
                      [&](const std::vector<records::WimRecord>& class_records, std::uint64_t class_seed) {
                        fleet::PosteriorCloud cloud = fit_smc(site_ptrs, class_records, fit, class_seed, progress);
                        for (std::size_t s = 0; s < cloud.sites.size(); ++s) cloud.sites[s].name = manifest.sites[s].name;
                        return cloud;
                      });
  if (progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    *progress << "ssrfleet fit: done in " << std::fixed << std::setprecision(1) << s << " s -> " << request.out << "\n";
  }
}

}  // namespace ssrfleet::cli
