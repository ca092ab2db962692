// The latent core drawing each new truck's latents from its table in a marginal fit of the same log
// (fleet/new_truck_proposals.hpp, FleetTarget::Options::proposals): the evidence it estimates is the
// one the marginal core and the prior-drawing latent core estimate, its bits do not depend on the
// thread count, it moves when its schedule says, and it refuses a log its tables were not built for.
#include <cmath>
#include <sstream>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/fleet_smc.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/new_truck_proposals.hpp"
#include "fleet/simulator.hpp"
#include "simulated_case.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

using namespace ssrfleet;

namespace {

using Case = test::SimulatedCase;

// The marginal fit whose tables propose the latent core's new trucks.
std::unique_ptr<fleet::MarginalSmc> marginal_fit(const Case& c, Eigen::Index particles, std::uint64_t seed) {
  fleet::MarginalSmc::Options o;
  o.sampler.particles = particles;
  o.sampler.threads = 2;
  o.sampler.seed = seed;
  auto fit = std::make_unique<fleet::MarginalSmc>(c.site, o);
  for (const auto& r : c.log.records) fit->absorb(r);
  return fit;
}

fleet::FleetSmc::Options latent_options(Eigen::Index particles, int threads, std::uint64_t seed,
                                        const fleet::NewTruckProposals* proposals) {
  fleet::FleetSmc::Options o;
  o.sampler.particles = particles;
  o.sampler.threads = threads;
  o.sampler.seed = seed;
  o.proposals = proposals;
  return o;
}

double latent_log_evidence(const Case& c, const fleet::FleetSmc::Options& o) {
  fleet::FleetSmc smc(c.site, o);
  for (const auto& r : c.log.records) smc.absorb(r);
  return smc.sampler().log_evidence();
}

std::string bytes_of(const fleet::FleetSmc& smc) {
  std::ostringstream os;
  BinaryWriter w(os);
  smc.save(w);
  return os.str();
}

}  // namespace

TEST_CASE("with table proposals the latent core estimates the evidence the marginal core and the prior-drawing "
          "latent core estimate",
          "[fleet][proposals][heavy]") {
  // 30 Table 1 trucks. The three estimates are of one number, log p(y_1..30); each has its own
  // Monte Carlo error, measured here over seeds rather than assumed: the test asks the means to
  // agree within 4 standard errors of their difference (plus 0.5 nats for the marginal core's
  // quadrature, whose error per truck is well under 0.01 nats: marginal_target.hpp).
  const Case c(30, 7);
  const auto tables_fit = marginal_fit(c, 512, 99);
  const fleet::MarginalTableProposals tables(tables_fit->target());
  constexpr int kSeeds = 6;
  std::vector<double> with_tables, from_prior, marginal;
  for (int s = 1; s <= kSeeds; ++s) {
    with_tables.push_back(latent_log_evidence(c, latent_options(256, 2, s, &tables)));
    from_prior.push_back(latent_log_evidence(c, latent_options(256, 2, s, nullptr)));
    marginal.push_back(marginal_fit(c, 256, s)->sampler().log_evidence());
  }
  const auto mean = [](const std::vector<double>& v) {
    double m = 0.0;
    for (double x : v) m += x;
    return m / static_cast<double>(v.size());
  };
  const auto variance_of_mean = [&](const std::vector<double>& v) {
    const double m = mean(v);
    double s = 0.0;
    for (double x : v) s += (x - m) * (x - m);
    return s / static_cast<double>(v.size() - 1) / static_cast<double>(v.size());
  };
  INFO("with tables " << mean(with_tables) << " (se " << std::sqrt(variance_of_mean(with_tables)) << "), from prior "
                      << mean(from_prior) << " (se " << std::sqrt(variance_of_mean(from_prior)) << "), marginal "
                      << mean(marginal) << " (se " << std::sqrt(variance_of_mean(marginal)) << ")");
  const double se_prior = std::sqrt(variance_of_mean(with_tables) + variance_of_mean(from_prior));
  const double se_marginal = std::sqrt(variance_of_mean(with_tables) + variance_of_mean(marginal));
  CHECK(std::abs(mean(with_tables) - mean(from_prior)) <= 4.0 * se_prior + 0.5);
  CHECK(std::abs(mean(with_tables) - mean(marginal)) <= 4.0 * se_marginal + 0.5);
}

TEST_CASE("with table proposals the latent core gives the same bits for one and two threads", "[fleet][proposals]") {
  const Case c(12, 3);
  const auto tables_fit = marginal_fit(c, 128, 5);
  const fleet::MarginalTableProposals tables(tables_fit->target());
  fleet::FleetSmc one(c.site, latent_options(96, 1, 11, &tables)), two(c.site, latent_options(96, 2, 11, &tables));
  for (const auto& r : c.log.records) {
    one.absorb(r);
    two.absorb(r);
  }
  CHECK(one.sampler().log_evidence() == two.sampler().log_evidence());
  CHECK(bytes_of(one) == bytes_of(two));
}

TEST_CASE("with table proposals the latent core moves after every stage of its first trucks, then only after "
          "resampling",
          "[fleet][proposals][schedule]") {
  const Case c(16, 4);
  const auto tables_fit = marginal_fit(c, 128, 6);
  const fleet::MarginalTableProposals tables(tables_fit->target());
  auto o = latent_options(128, 2, 12, &tables);
  o.every_stage_moves_until = 5;
  fleet::FleetSmc smc(c.site, o);
  int quiet_stages = 0;
  for (std::size_t t = 0; t < c.log.records.size(); ++t) {
    const smc::StageSummary& stage = smc.absorb(c.log.records[t]);
    bool moved = false;
    for (const auto& step : stage.steps) {
      // No random-walk block while the newest truck is the proposal's (FleetTarget::blocks).
      CHECK(step.mh.block_names.empty());
      moved = moved || step.mh.sweeps > 0;
    }
    INFO("truck " << (t + 1) << ": " << stage.resamplings() << " resamplings");
    if (t + 1 <= 5) {
      CHECK(moved);  // every stage of the first five
    } else {
      CHECK(moved == (stage.resamplings() > 0));  // IBIS afterwards
      quiet_stages += moved ? 0 : 1;
    }
  }
  CHECK(quiet_stages > 0);  // the point of it: some stages cost no moves at all
}

TEST_CASE("a latent core refuses a truck its table proposals were not built for", "[fleet][proposals]") {
  const Case c(6, 8), other(6, 9);
  const auto tables_fit = marginal_fit(c, 64, 1);
  const fleet::MarginalTableProposals tables(tables_fit->target());
  fleet::FleetSmc smc(c.site, latent_options(64, 1, 1, &tables));
  smc.absorb(c.log.records[0]);
  CHECK_THROWS_WITH(smc.absorb(other.log.records[1]), Catch::Contains("not the truck its proposals were built for"));
  // Past the trucks the tables hold: no table for the seventh truck either.
  fleet::FleetSmc longer(c.site, latent_options(64, 1, 1, &tables));
  for (const auto& r : c.log.records) longer.absorb(r);
  CHECK_THROWS_AS(longer.absorb(other.log.records[0]), UsageError);
}
