// What OnlineFit tells a caller without the caller knowing its core (fleet/online_fit.hpp): the
// integrator's passes, the tables' time, whether a truck holds a record's data, the tables as
// proposals, and the one core a visitor is handed.
#include <string>

#include <catch2/catch.hpp>

#include "fleet/online_fit.hpp"
#include "simulated_case.hpp"

using namespace ssrfleet;

namespace {

std::unique_ptr<fleet::OnlineFit> fitted(const test::SimulatedCase& c, fleet::Core core) {
  fleet::OnlineFitOptions o;
  o.core = fleet::choose_core(nullptr, core);
  o.sampler().particles = 32;
  o.sampler().threads = 1;
  o.sampler().seed = 5;
  auto fit = fleet::make_online_fit(c.site, o);
  for (const auto& r : c.log.records) fit->absorb(r);
  return fit;
}

// Which core the visitor was handed: "latent" or "marginal".
std::string visited(const fleet::OnlineFit& fit) {
  return fleet::visit_core(
      fit, [](const fleet::FleetSmc&) { return std::string("latent"); },
      [](const fleet::MarginalSmc&) { return std::string("marginal"); });
}

}  // namespace

TEST_CASE("an online fit answers for its core: the visitor, integrator passes, tables, records and proposals",
          "[online_fit]") {
  const test::SimulatedCase c(6, 3);
  const auto& records = c.log.records;

  const auto marginal = fitted(c, fleet::Core::kMarginal);
  CHECK(marginal->core() == "marginal");
  CHECK(visited(*marginal) == "marginal");
  CHECK(fleet::visit_core(
            *marginal, [](const fleet::FleetSmc&) { return -1LL; },
            [](const fleet::MarginalSmc& m) { return m.target().integrator_passes(); }) == marginal->integrator_passes());
  CHECK(marginal->integrator_passes() > 0);  // every truck's table is built by the integrator
  REQUIRE(marginal->table_seconds().has_value());
  CHECK(*marginal->table_seconds() > 0.0);
  for (std::size_t i = 0; i < records.size(); ++i) CHECK(marginal->holds_record(i, records[i]));
  records::WimRecord edited = records[2];
  edited.impact_factor[0] += 1e-9;  // an edit a resumed fit must notice
  CHECK_FALSE(marginal->holds_record(2, edited));
  edited = records[2];
  edited.speed_mps += 0.5;
  CHECK_FALSE(marginal->holds_record(2, edited));
  CHECK_FALSE(marginal->holds_record(1, records[2]));
  const auto proposals = marginal->table_proposals();
  REQUIRE(proposals != nullptr);
  CHECK(proposals->matches(4, records[4].speed_mps, records[4].sprung_mass_kg));
  CHECK_FALSE(proposals->matches(4, records[4].speed_mps + 1.0, records[4].sprung_mass_kg));

  const auto latent = fitted(c, fleet::Core::kLatent);
  CHECK(latent->core() == "latent");
  CHECK(visited(*latent) == "latent");
  CHECK(fleet::visit_core(
            *latent, [](const fleet::FleetSmc& l) { return l.target().integrator_passes(); },
            [](const fleet::MarginalSmc&) { return -1LL; }) == latent->integrator_passes());
  CHECK(latent->integrator_passes() > 0);  // every particle's trucks are simulated
  CHECK_FALSE(latent->table_seconds().has_value());
  CHECK(latent->table_proposals() == nullptr);
  CHECK(latent->holds_record(2, records[2]));  // no data of its own to compare: nothing refused
}
