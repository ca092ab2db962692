#include "fit_sites.hpp"

#include <chrono>
#include <iomanip>
#include <iostream>
#include <memory>

#include "fleet/joint_sites.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/posterior_json.hpp"
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
  // Sites live on the heap: the fit keeps pointers to them.
  std::vector<std::unique_ptr<site::Site>> sites;
  std::vector<const site::Site*> site_ptrs;
  std::vector<std::vector<records::WimRecord>> per_site;
  for (const io::ManifestSite& entry : manifest.sites) {
    SiteFlags flags = site_flags;
    sites.push_back(std::make_unique<site::Site>(site_of_manifest_entry(manifest, entry, flags, &std::cerr)));
    site_ptrs.push_back(sites.back().get());
    per_site.push_back(read_manifest_site_log(manifest, entry, *sites.back(), flags, limits));
    // Ids are per site (the same id at two sites is two trucks): kept as SITE:ID, as a stream does.
    for (auto& r : per_site.back()) r.truck_id = entry.name + ":" + r.truck_id;
    if (progress) {
      *progress << "ssrfleet fit: site " << entry.name << ": " << per_site.back().size() << " trucks from "
                << entry.log << ", road " << sites.back()->surface().name << ", " << sites.back()->sensors()
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
  fleet::ClassPosteriors classes;
  std::vector<std::vector<fleet::ParameterSummary>> hyper, psi;
  for (const auto& [label, class_records] : fleet::split_by_class(records)) {
    const std::uint64_t class_seed = fleet::class_seed(request.seed, label);
    if (progress && !label.empty()) {
      *progress << "ssrfleet fit: class " << label << ": " << class_records.size() << " trucks, seed " << class_seed << "\n";
    }
    fleet::PosteriorCloud cloud = fit_smc(site_ptrs, class_records, fit, class_seed, progress);
    for (std::size_t s = 0; s < cloud.sites.size(); ++s) cloud.sites[s].name = manifest.sites[s].name;
    hyper.push_back(fleet::summarise_cloud(cloud));
    psi.push_back(fleet::summarise_psi(cloud));
    classes.push_back({label, std::move(cloud)});
  }
  write_output(request.out,
               [&](std::ostream& os) { os << io::posterior_file_text(io::posterior_classes_to_json(classes, hyper, psi)); });
  if (progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    *progress << "ssrfleet fit: done in " << std::fixed << std::setprecision(1) << s << " s -> " << request.out << "\n";
  }
}

}  // namespace ssrfleet::cli
