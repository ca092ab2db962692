// A marginal fit split over ranks (util/ranks.hpp; docs/sites.md), with threads standing
// in for MPI ranks (thread_ranks.hpp): the same bits as one process for any rank count, and a
// checkpoint written on some ranks resumes on any other number.
#include <map>
#include <mutex>
#include <sstream>

#include <catch2/catch.hpp>

#include "test_support.hpp"
#include "thread_ranks.hpp"

#include "fleet/marginal_smc.hpp"
#include "fleet/online_fit.hpp"
#include "io/fit_checkpoint.hpp"
#include "io/write_faults.hpp"
#include "util/errors.hpp"
#include "fleet/joint_sites.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "site/road_source.hpp"
#include "util/binary_io.hpp"

using namespace ssrfleet;

namespace {

// Two sites (AS1 with 16 sensors, AS3 with 12) and their trucks merged as fit --sites merges them.
struct TwoSites {
  site::Site as1{site::load_road("AS1"), site::SiteOptions{}};
  site::Site as3{site::load_road("AS3"), [] {
                   site::SiteOptions o;
                   o.sensors.count = 12;
                   return o;
                 }()};
  std::vector<const site::Site*> sites{&as1, &as3};
  std::vector<records::WimRecord> records;
  TwoSites(int per_site, std::uint64_t seed) {
    std::vector<std::vector<records::WimRecord>> logs;
    for (std::uint32_t s = 0; s < 2; ++s) {
      const site::Site& site = *sites[s];
      const auto trucks = fleet::draw_fleet(fleet::FleetDistribution{}, per_site, site.lateral_min_m(),
                                            site.lateral_max_m(), seed + s);
      auto log = fleet::simulate_log(site, trucks, 0.02, seed + 10 + s).records;
      for (auto& r : log) r.site = s;
      logs.push_back(std::move(log));
    }
    records = fleet::merge_site_records(std::move(logs));
  }
};

fleet::MarginalSmc::Options options(const util::Ranks* ranks) {
  fleet::MarginalSmc::Options o;
  o.sampler.particles = 96;
  o.sampler.threads = 1;
  o.sampler.seed = 17;
  o.target.ranks = ranks;
  return o;
}

// fit's way: tables prebuilt ahead of each absorb, from record `from` to `to`.
void absorb(fleet::MarginalSmc& smc, const std::vector<records::WimRecord>& records, std::size_t from, std::size_t to) {
  for (std::size_t i = from; i < to; ++i) {
    smc.prepare(records, i);
    smc.absorb(records[i]);
  }
}

// A checkpoint as a stream or fit --checkpoint keeps it: the fixed-size state and the truck records
// (on several ranks each record comes from its truck's rank). Collective on several ranks: rank 0
// gets the bytes, the others none.
struct Checkpoint {
  std::string state, trucks;
  bool operator==(const Checkpoint&) const = default;
};
Checkpoint bytes_of(const fleet::MarginalSmc& smc) {
  std::ostringstream state, trucks;
  BinaryWriter s(state), t(trucks);
  smc.save_state(s);
  smc.save_trucks(t, 0, static_cast<std::size_t>(smc.trucks_seen()));
  return {state.str(), trucks.str()};
}

void restore_from(fleet::MarginalSmc& smc, const Checkpoint& bytes) {
  std::istringstream state(bytes.state), trucks(bytes.trucks);
  BinaryReader s(state, "checkpoint"), t(trucks, "truck log");
  smc.restore_split(s, t);
}

}  // namespace

TEST_CASE("a marginal fit of two sites split over 2 or 3 ranks has the bits of one process", "[marginal][ranks][heavy]") {
  const TwoSites c(30, 3);
  fleet::MarginalSmc one(c.sites, options(nullptr));
  absorb(one, c.records, 0, c.records.size());
  one.rejuvenate(3);
  const Checkpoint expected = bytes_of(one);
  REQUIRE(one.target().rebuilds() >= 2);  // the rebuilds' exact sums are split too
  for (int ranks : {2, 3}) {
    std::mutex m;
    std::map<int, Checkpoint> bytes;
    std::map<int, bool> same_theta;
    testing::run_on_ranks(ranks, [&](const util::Ranks& r) {
      fleet::MarginalSmc split(c.sites, options(&r));
      absorb(split, c.records, 0, c.records.size());
      split.rejuvenate(3);
      const Checkpoint b = bytes_of(split);
      // Each rank keeps only its own trucks' tables, about 1/ranks of them.
      const auto local = static_cast<long>(split.target().tables().trucks());
      const long n = static_cast<long>(c.records.size());
      CHECK(local == (n - r.rank() + r.size() - 1) / r.size());
      std::lock_guard lock(m);
      bytes[r.rank()] = b;
      same_theta[r.rank()] = split.target().theta() == one.target().theta();
    });
    INFO(ranks << " ranks");
    CHECK(bytes[0] == expected);  // particles, weights, every truck's record and table, in order
    for (int k = 0; k < ranks; ++k) CHECK(same_theta[k]);
  }
}

TEST_CASE("a checkpoint of a fit on 3 ranks resumes on 2 ranks and on one process with the bits of a straight run",
          "[marginal][ranks]") {
  const TwoSites c(30, 8);
  const std::size_t cut = 35, n = c.records.size();
  fleet::MarginalSmc straight(c.sites, options(nullptr));
  absorb(straight, c.records, 0, n);
  const Checkpoint expected = bytes_of(straight);

  Checkpoint checkpoint;
  testing::run_on_ranks(3, [&](const util::Ranks& r) {
    fleet::MarginalSmc first(c.sites, options(&r));
    absorb(first, c.records, 0, cut);
    const Checkpoint b = bytes_of(first);
    if (r.rank() == 0) checkpoint = b;
  });
  fleet::MarginalSmc single_to_cut(c.sites, options(nullptr));
  absorb(single_to_cut, c.records, 0, cut);
  CHECK(checkpoint == bytes_of(single_to_cut));  // the file one process would write

  Checkpoint resumed_on_two;
  testing::run_on_ranks(2, [&](const util::Ranks& r) {
    fleet::MarginalSmc resumed(c.sites, options(&r));
    restore_from(resumed, checkpoint);
    absorb(resumed, c.records, cut, n);
    const Checkpoint b = bytes_of(resumed);
    if (r.rank() == 0) resumed_on_two = b;
  });
  CHECK(resumed_on_two == expected);
  fleet::MarginalSmc resumed_alone(c.sites, options(nullptr));
  restore_from(resumed_alone, checkpoint);
  absorb(resumed_alone, c.records, cut, n);
  CHECK(bytes_of(resumed_alone) == expected);
}

TEST_CASE("a fit checkpoint that a full disk stops throws on rank 0 after its part in the collectives, and the last one "
          "stays whole",
          "[marginal][ranks][checkpoint]") {
  const TwoSites c(12, 5);
  test::TempDir dir;
  const std::string path = dir.file("fit.ckpt");
  const std::string options_text = "particles=96";
  std::mutex m;
  std::map<int, std::string> outcome;
  testing::run_on_ranks(2, [&](const util::Ranks& r) {
    fleet::OnlineFitOptions o;
    o.marginal = options(&r);
    auto fit = fleet::make_online_fit(c.sites, o);
    for (std::size_t i = 0; i < 14; ++i) fit->absorb(c.records[i]);
    io::write_fit_checkpoint(path, *fit, r, options_text);
    for (std::size_t i = 14; i < 18; ++i) fit->absorb(c.records[i]);
    if (r.rank() == 0) io::arm_write_fault(1);  // rank 0's next write finds the disk full
    std::string what = "written";
    try {
      io::write_fit_checkpoint(path, *fit, r, options_text);
    } catch (const IoError& e) {
      what = e.what();
    }
    if (r.rank() == 0) io::disarm_write_fault();
    // The ranks are still in step: the next truck's collectives match.
    fit->absorb(c.records[18]);
    std::lock_guard lock(m);
    outcome[r.rank()] = what;
  });
  CHECK(outcome[0].find("No space left on device") != std::string::npos);
  CHECK(outcome[1] == "written");  // rank 1 writes nothing: it cannot fail
  // The file is the first checkpoint, whole: it resumes at truck 14.
  fleet::OnlineFitOptions o;
  o.marginal = options(nullptr);
  auto resumed = fleet::make_online_fit(c.sites, o);
  CHECK(io::read_fit_checkpoint(path, *resumed, c.records, options_text) == 14);
}
