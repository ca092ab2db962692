// Several sites, one fleet (fleet/joint_sites.hpp): the per-site constants of the
// marginal likelihood, the merge of the sites' logs, and the joint posterior: sharper than each
// site's alone, covering the truth, and as reproducible as a fit of one site.
#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include <catch2/catch.hpp>

#include "fleet/joint_sites.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/online_fit.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/replay.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/fleet_marginal.hpp"
#include "model/truck_table.hpp"
#include "site/road_source.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

site::Site make_site(const char* road, double first_m, double spacing_m, int count) {
  site::SiteOptions o;
  o.sensors = {first_m, spacing_m, count};
  return site::Site(site::load_road(road), o);
}

// Three sites on different roads and sensor arrays, one fleet (Table 1), `n` trucks each.
struct ThreeSites {
  std::vector<std::unique_ptr<site::Site>> sites;
  std::vector<std::vector<records::WimRecord>> logs;
  explicit ThreeSites(int n) {
    sites.push_back(std::make_unique<site::Site>(make_site("AS1", 76.0, 1.5, 16)));
    sites.push_back(std::make_unique<site::Site>(make_site("AS2", 70.0, 2.0, 8)));
    sites.push_back(std::make_unique<site::Site>(make_site("AS3", 60.0, 1.5, 12)));
    for (std::size_t s = 0; s < sites.size(); ++s) {
      const site::Site& site = *sites[s];
      const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, n, site.lateral_min_m(), site.lateral_max_m(), 40 + s);
      logs.push_back(fleet::simulate_log(site, trucks, 0.02, 50 + s).records);
    }
  }
  std::vector<const site::Site*> pointers() const {
    std::vector<const site::Site*> p;
    for (const auto& s : sites) p.push_back(s.get());
    return p;
  }
};

fleet::OnlineFitOptions fit_options(Eigen::Index particles, int threads, std::uint64_t seed) {
  fleet::OnlineFitOptions o;
  o.marginal.sampler.particles = particles;
  o.marginal.sampler.threads = threads;
  o.marginal.sampler.seed = seed;
  return o;
}

std::string bytes_of(const fleet::OnlineFit& fit) {
  std::ostringstream os;
  BinaryWriter w(os);
  fit.save(w);
  return os.str();
}

}  // namespace

TEST_CASE("merge_site_records keeps each log's order, stamps its site and spreads every site over the sequence",
          "[joint_sites]") {
  std::vector<std::vector<records::WimRecord>> per_site(3);
  const std::size_t sizes[3] = {10, 3, 7};
  for (std::size_t s = 0; s < 3; ++s) {
    for (std::size_t k = 0; k < sizes[s]; ++k) {
      records::WimRecord r;
      r.truck_id = "T";  // the same ids at every site: trucks of different sites
      r.truck_id += std::to_string(k);
      r.line = k + 2;
      r.site = 99;  // overwritten by the merge
      per_site[s].push_back(r);
    }
  }
  const auto merged = fleet::merge_site_records(per_site);
  REQUIRE(merged.size() == 20);
  std::size_t seen[3] = {0, 0, 0};
  for (std::size_t i = 0; i < merged.size(); ++i) {
    const auto s = merged[i].site;
    REQUIRE(s < 3);
    CHECK(merged[i].line == seen[s] + 2);  // the log's own order
    ++seen[s];
    // Every prefix holds each site in proportion to its log, to within one record.
    for (std::size_t t = 0; t < 3; ++t) {
      const double expected = static_cast<double>(i + 1) * static_cast<double>(sizes[t]) / 20.0;
      CHECK(std::abs(static_cast<double>(seen[t]) - expected) <= 1.0 + 1e-12);
    }
  }
  for (std::size_t s = 0; s < 3; ++s) CHECK(seen[s] == sizes[s]);
}

TEST_CASE("a truck's marginal likelihood over several sites is its own site's, to the bit", "[joint_sites]") {
  ThreeSites c(2);
  const site::Site& b = *c.sites[1];
  const auto& r = c.logs[1][0];
  model::TruckTableOptions o;
  o.sigma_ref = 0.02;
  const model::TruckFit fit = model::fit_truck(b, r.speed_mps, r.sprung_mass_kg, r.impact_factor, o);
  model::Lattice lattice;
  lattice.k_origin_npm = fit.stiffness_npm;
  lattice.kt_origin_npm = fit.tyre_stiffness_npm;
  lattice.dk_npm = 20e3;
  lattice.dkt_npm = 80e3;
  const model::TruckTable table = model::build_truck_table(b, r.speed_mps, r.sprung_mass_kg, r.impact_factor, lattice, o, fit);
  model::TableStore store;
  store.append(table, 1);

  std::vector<model::SiteConstants> constants;
  for (const auto* s : c.pointers()) constants.push_back({s->sensors(), {s->lateral_min_m(), s->lateral_max_m()}});
  const model::FleetMarginal joint(constants, lattice);
  const model::FleetMarginal alone(b.sensors(), {b.lateral_min_m(), b.lateral_max_m()}, lattice);
  for (const fleet::HyperVector theta : {fleet::HyperVector{500e3, 50e3, 1950e3, 195e3, 1.5, 0.5, 0.02},
                                         fleet::HyperVector{450e3, 80e3, 2100e3, 150e3, 1.2, 0.3, 0.03}}) {
    const double l_joint = joint.log_likelihood(store.view(0), joint.prepare(theta));
    const double l_alone = alone.log_likelihood(view_of(table), alone.prepare(theta));
    CHECK(std::isfinite(l_alone));
    CHECK(l_joint == l_alone);
    // The same table read as a truck of site 0 (16 sensors, another lane) gives another value: the
    // constant is the site's, not the first one's.
    model::TableStore as_a;
    as_a.append(table, 0);
    CHECK(joint.log_likelihood(as_a.view(0), joint.prepare(theta)) != l_alone);
  }
}

TEST_CASE("the joint log posterior of several sites is the sum of each site's, up to the tables' quadrature",
          "[joint_sites][heavy]") {
  ThreeSites c(12);
  fleet::MarginalSmc joint(c.pointers(), fleet::MarginalSmc::Options{});
  for (const auto& r : fleet::merge_site_records(c.logs)) joint.absorb(r);
  std::vector<std::unique_ptr<fleet::MarginalSmc>> alone;
  for (std::size_t s = 0; s < 3; ++s) {
    alone.push_back(std::make_unique<fleet::MarginalSmc>(*c.sites[s], fleet::MarginalSmc::Options{}));
    for (const auto& r : c.logs[s]) alone.back()->absorb(r);
  }
  const fleet::PriorBounds prior;
  for (const fleet::HyperVector theta : {fleet::HyperVector{500e3, 50e3, 1950e3, 195e3, 1.5, 0.5, 0.02},
                                         fleet::HyperVector{520e3, 40e3, 1900e3, 230e3, 1.6, 0.45, 0.021}}) {
    double sum = -2.0 * prior.log_prior(theta);
    for (const auto& a : alone) sum += a->target().log_posterior(theta);
    const double j = joint.target().log_posterior(theta);
    // The two sides' tables differ (each fit sets its own lattice and keeps nodes for its own
    // posterior), each within its approximation budget of the exact marginal: the lateral pieces err
    // by up to 0.004 nats per truck on AS2 (marginal_target.hpp, lateral_piece_fraction), so 36
    // trucks by up to 0.15 on either side. A wrong site constant (the 16 sensors of AS1 for a truck
    // of AS2's 8) would be off by 4 log(u / 2π) ≈ 24 nats per truck of that site.
    CHECK(j == Approx(sum).margin(36 * 0.004));
  }
}

TEST_CASE("a fit of three sites is sharper than each site's alone and covers the fleet's truth", "[joint_sites][heavy]") {
  ThreeSites c(80);
  const fleet::HyperVector truth{500e3, 50e3, 1950e3, 195e3, 1.5, 0.5, 0.02};
  auto joint = fleet::make_online_fit(c.pointers(), fit_options(1024, 2, 5));
  fleet::replay(*joint, fleet::merge_site_records(c.logs), {});
  const fleet::PosteriorCloud cloud = joint->cloud();
  const auto j = fleet::summarise_cloud(cloud);
  REQUIRE(cloud.sites.size() == 3);
  for (std::size_t s = 0; s < 3; ++s) {
    CHECK(cloud.sites[s].trucks_seen == 80);
    CHECK(cloud.sites[s].pool_count == 80);
    CHECK(cloud.sites[s].fingerprint == c.sites[s]->fingerprint());
    CHECK(cloud.sites[s].sensors == c.sites[s]->sensors());
  }
  CHECK(cloud.trucks_seen == 240);
  CHECK(cloud.site_fingerprint == fleet::sites_fingerprint(c.pointers()));

  for (std::size_t s = 0; s < 3; ++s) {
    auto alone = fleet::make_online_fit(*c.sites[s], fit_options(1024, 2, 5));
    fleet::replay(*alone, c.logs[s], {});
    const auto a = fleet::summarise_cloud(alone->cloud());
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      INFO("site " << s << ", " << fleet::kHyperNames[static_cast<std::size_t>(h)] << ": joint sd " << j[h].sd
                   << ", alone " << a[h].sd);
      // Three sites' information: about 1/√3 of one site's sd; the Monte Carlo error of an sd from
      // 1,024 particles is a few per cent.
      CHECK(j[h].sd < 0.9 * a[h].sd);
    }
  }
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    INFO(fleet::kHyperNames[static_cast<std::size_t>(h)] << ": " << j[h].mean << " +- " << j[h].sd << ", truth "
                                                          << truth[static_cast<std::size_t>(h)]);
    CHECK(std::abs(j[h].mean - truth[static_cast<std::size_t>(h)]) < 3.0 * j[h].sd);
  }
}

TEST_CASE("a fit of several sites resumes bit-identically at any thread count, and refuses another set of sites",
          "[joint_sites][heavy]") {
  ThreeSites c(10);
  const auto records = fleet::merge_site_records(c.logs);
  auto straight = fleet::make_online_fit(c.pointers(), fit_options(64, 2, 8));
  for (const auto& r : records) straight->absorb(r);

  auto first = fleet::make_online_fit(c.pointers(), fit_options(64, 2, 8));
  for (std::size_t t = 0; t < 17; ++t) first->absorb(records[t]);
  const std::string saved = bytes_of(*first);
  auto resumed = fleet::make_online_fit(c.pointers(), fit_options(64, 1, 8));
  {
    std::istringstream is(saved);
    BinaryReader in(is, "checkpoint.bin");
    resumed->restore(in);
  }
  for (std::size_t t = 17; t < records.size(); ++t) resumed->absorb(records[t]);
  CHECK(bytes_of(*resumed) == bytes_of(*straight));

  // The same sites in another order are another fit: a record's site index would mean another site.
  std::vector<const site::Site*> swapped = c.pointers();
  std::swap(swapped[0], swapped[1]);
  auto other = fleet::make_online_fit(swapped, fit_options(64, 2, 8));
  std::istringstream is(saved);
  BinaryReader in(is, "state/checkpoint.bin");
  CHECK_THROWS_WITH(other->restore(in), Catch::Contains("state/checkpoint.bin") && Catch::Contains("another site"));
}

TEST_CASE("a record of a site the fit does not have, or several sites on the latent core, is refused", "[joint_sites]") {
  ThreeSites c(2);
  auto two = fleet::make_online_fit({c.sites[0].get(), c.sites[1].get()}, fit_options(16, 1, 1));
  records::WimRecord r = c.logs[2][0];
  r.site = 2;
  CHECK_THROWS_AS(two->absorb(r), UsageError);
  // A site's record with another site's sensor count.
  r = c.logs[0][0];
  r.site = 1;
  CHECK_THROWS_AS(two->absorb(r), DataError);

  fleet::OnlineFitOptions latent = fit_options(16, 1, 1);
  latent.core = fleet::OnlineFitOptions::Core::kLatent;
  CHECK_THROWS_WITH(fleet::make_online_fit(c.pointers(), latent), Catch::Contains("marginal core"));
  auto one = fleet::make_online_fit(*c.sites[0], latent);
  r = c.logs[0][0];
  r.site = 1;
  CHECK_THROWS_AS(one->absorb(r), UsageError);
}

TEST_CASE("cloud_at_site narrows a joint posterior to one site's traffic and fingerprint", "[joint_sites]") {
  fleet::PosteriorCloud c;
  c.speed_mps = {20, 21, 22, 23, 24};
  c.sprung_mass_kg = {4000, 4100, 4200, 4300, 4400};
  c.sites = {{"north", "fa", "AS1", 16, 0.0, 3.5, 3, 0, 3}, {"south", "fb", "AS2", 8, 0.2, 3.0, 2, 3, 2},
             {"west", "fc", "AS3", 12, 0.0, 3.5, 0, 5, 0}};
  const auto south = fleet::cloud_at_site(c, fleet::find_cloud_site(c, "south", "p.json"));
  CHECK(south.speed_mps == std::vector<double>{23, 24});
  CHECK(south.sprung_mass_kg == std::vector<double>{4300, 4400});
  CHECK(south.trucks_seen == 2);  // its own trucks: a class's share at the site
  CHECK(south.site_fingerprint == "fb");
  CHECK(south.sensors == 8);
  CHECK(south.lateral_min_m == 0.2);
  CHECK(south.sites.empty());
  // A site with no trucks of its own (in this vehicle class): every site's traffic.
  CHECK(fleet::cloud_at_site(c, 2).speed_mps == c.speed_mps);
  CHECK(fleet::cloud_at_site(c, 2).trucks_seen == 0);
  CHECK_THROWS_WITH(fleet::find_cloud_site(c, "east", "p.json"), Catch::Contains("north, south, west"));
  fleet::PosteriorCloud one;
  CHECK_THROWS_WITH(fleet::find_cloud_site(one, "east", "p.json"), Catch::Contains("one site"));
}
