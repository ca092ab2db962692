// Several sites, one fleet (docs/sites.md): what a fit over many sites needs beyond one
// site's fit. The sites share the fleet's hyperparameters θ; each truck's table is built through
// the site that logged it (WimRecord::site), so the marginal core fits them all at once
// (MarginalTarget, model/fleet_marginal.hpp).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "fleet/posterior_cloud.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::fleet {

// What a checkpoint and a posterior of these sites are tied to: the site's own fingerprint for one
// site, "sites:" and every site's fingerprint in order for several (the order indexes WimRecord::site).
std::string sites_fingerprint(const std::vector<const site::Site*>& sites);

// The records of every site in one sequence, each stamped with its site's index (WimRecord::site =
// its position in `per_site`) and merged by their fraction of their own site's log: the k-th of n
// records of a site goes at k / n, ties broken by site order. A log's own order is kept, and every
// prefix of the sequence holds each site in proportion to its log, so the tables' settings and the
// early posterior see every site from the start (the posterior of the whole does not depend on the
// order; its Monte Carlo error does).
std::vector<records::WimRecord> merge_site_records(std::vector<std::vector<records::WimRecord>> per_site);

// A site's sensors read gain x the true impact factor (a calibration, known or fitted: docs/sites.md):
// divides each of the record's impact factors by its sensor's gain, so the fleet model
// sees the true ones. Every gain must be positive; std::invalid_argument if the counts differ.
void remove_sensor_gains(records::WimRecord& record, const Eigen::VectorXd& gains);

// The cloud of a fit over several sites seen from one of them: the site's fields at the top level,
// its own trucks as trucks_seen and as the speed and mass pool (every site's pool when it has no
// trucks: a vehicle class may skip a site, a young stream may not have reached it; trucks_seen is
// then 0, and a caller weighing classes by their trucks there falls back on the whole's), no site
// list, and only that site's sensor calibration. The posterior of θ is the joint one.
// std::out_of_range if `site` is not an index of cloud.sites.
PosteriorCloud cloud_at_site(const PosteriorCloud& cloud, std::size_t site);
// The index in cloud.sites of the site named `name`; UsageError listing the names otherwise.
std::size_t find_cloud_site(const PosteriorCloud& cloud, const std::string& name, const std::string& posterior_path);

}  // namespace ssrfleet::fleet
