// The posterior file's checksum: a file cut short or with a byte changed is a
// DataError naming the file, never a wrong posterior; re-indenting it, or a file without a
// checksum, still reads.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include <catch2/catch.hpp>

#include "fleet/posterior_summary.hpp"
#include "io/posterior_json.hpp"
#include "model/fleet_model.hpp"
#include "test_support.hpp"

using namespace ssrfleet;

namespace {
// A small cloud with values that use every digit a double has (a changed digit is a changed value).
fleet::PosteriorCloud random_cloud(int draws, unsigned seed, bool with_psi) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z(0.0, 1.0);
  fleet::PosteriorCloud c;
  c.method = "smc";
  c.theta.resize(fleet::kHyperCount, draws);
  c.weights.resize(draws);
  for (int i = 0; i < draws; ++i) {
    for (int h = 0; h < fleet::kHyperCount; ++h) c.theta(h, i) = 1.0 + 0.1 * z(rng);
    c.weights[i] = 0.5 + 0.1 * std::abs(z(rng));
  }
  c.weights /= c.weights.sum();
  for (int t = 0; t < 5; ++t) {
    c.speed_mps.push_back(20.0 + z(rng));
    c.sprung_mass_kg.push_back(5000.0 + 100.0 * z(rng));
  }
  c.site_fingerprint = "AS1/76,1.5,16";
  c.road_name = "AS1";
  c.sensors = 16;
  c.lateral_min_m = 0.5;
  c.lateral_max_m = 2.5;
  c.trucks_seen = 5;
  c.weight_ess = 17.25;
  c.log_evidence = -123.456789;
  if (with_psi) {
    c.model = "sensor_gain:sensor=11";
    c.psi_names = {"gain"};
    c.psi.resize(1, draws);
    for (int i = 0; i < draws; ++i) c.psi(0, i) = 1.0 + 0.01 * z(rng);
  }
  return c;
}

void write(const std::string& path, const fleet::PosteriorCloud& c) {
  io::write_posterior_file(path, c, fleet::summarise_cloud(c), fleet::summarise_psi(c));
}

bool same(const fleet::PosteriorCloud& a, const fleet::PosteriorCloud& b) {
  return a.theta == b.theta && (a.weights == b.weights).all() && a.speed_mps == b.speed_mps &&
         a.sprung_mass_kg == b.sprung_mass_kg && a.site_fingerprint == b.site_fingerprint && a.model == b.model &&
         a.psi == b.psi && a.trucks_seen == b.trucks_seen && a.weight_ess == b.weight_ess && (a.min_ess == b.min_ess || (std::isnan(a.min_ess) && std::isnan(b.min_ess))) && a.sensors == b.sensors &&
         a.pooled_sweeps == b.pooled_sweeps;
}
}  // namespace

TEST_CASE("a posterior file carries a checksum and reads back bit for bit", "[io][posterior]") {
  test::TempDir dir;
  for (const bool with_psi : {false, true}) {
    const auto cloud = random_cloud(40, 7, with_psi);
    const std::string path = dir.file("p.json");
    write(path, cloud);
    const std::string text = test::read_text(path);
    CHECK(text.find("\"checksum\": \"fnv1a64:") != std::string::npos);
    const auto back = io::read_posterior_file(path);
    CHECK(same(back, cloud));
    // Re-indented (what a person's editor or `jq .` may do) it is the same content: still read.
    test::write_text(path, nlohmann::json::parse(text).dump(4));
    CHECK(same(io::read_posterior_file(path), cloud));
  }
}

TEST_CASE("a posterior file cut at any 1 KiB offset or with any byte flipped is refused by name or reads the same",
          "[io][posterior][heavy]") {
  test::TempDir dir;
  const auto cloud = random_cloud(64, 11, true);
  const std::string path = dir.file("posterior.json");
  write(path, cloud);
  const std::string good = test::read_text(path);
  REQUIRE(good.size() > 4096);

  int cuts = 0, cuts_refused = 0;
  for (std::size_t at = 0; at < good.size(); at += 1024) {
    ++cuts;
    test::write_text(path, good.substr(0, at));
    const auto e = test::data_error([&] { io::read_posterior_file(path); });
    INFO("cut at " << at);
    REQUIRE(e);
    CHECK(e->file() == path);
    cuts_refused += 1;
  }
  CHECK(cuts_refused == cuts);

  // Every byte, one at a time, with one bit flipped. Bit 0 turns a digit into another digit, so the
  // file stays valid JSON with another value: only the checksum can catch that. Bit 4 turns digits
  // and white space into punctuation: mostly invalid JSON. Either way a flip is a refusal naming the
  // file, or (a flip in a name the reader does not need, such as "checksum" itself) the very same
  // posterior.
  for (const int bit : {0x01, 0x10}) {
    int refused = 0, by_checksum = 0, read_same = 0;
    for (std::size_t at = 0; at < good.size(); ++at) {
      std::string damaged = good;
      damaged[at] = static_cast<char>(damaged[at] ^ bit);
      test::write_text(path, damaged);
      try {
        const auto back = io::read_posterior_file(path);
        INFO("bit " << bit << " flipped at " << at << " read without an error");
        CHECK(same(back, cloud));
        ++read_same;
      } catch (const DataError& e) {
        INFO("bit " << bit << " flipped at " << at << ": " << e.what());
        CHECK(e.file() == path);
        ++refused;
        by_checksum += e.field() == "checksum";
      }
    }
    INFO("bit " << bit << ": " << refused << " refused (" << by_checksum << " by the checksum), " << read_same
                << " read the same, of " << good.size());
    CHECK(refused + read_same == static_cast<int>(good.size()));
    if (bit == 0x01) CHECK(by_checksum > static_cast<int>(good.size()) / 3);
  }
}

TEST_CASE("a posterior file edited by hand fails its checksum, and one without a checksum is read as it is",
          "[io][posterior]") {
  test::TempDir dir;
  const auto cloud = random_cloud(8, 3, false);
  const std::string path = dir.file("p.json");
  write(path, cloud);
  auto j = nlohmann::json::parse(test::read_text(path));
  j["cloud"]["weights"][0] = 0.9;  // still valid JSON, still a plausible posterior
  test::write_text(path, j.dump(1));
  const auto e = test::data_error([&] { io::read_posterior_file(path); });
  REQUIRE(e);
  CHECK(e->field() == "checksum");
  CHECK(std::string(e->what()).find(path) != std::string::npos);

  j["checksum"] = 12;
  test::write_text(path, j.dump(1));
  const auto wrong_type = test::data_error([&] { io::read_posterior_file(path); });
  REQUIRE(wrong_type);
  CHECK(wrong_type->field() == "checksum");

  j.erase("checksum");  // a file of an older ssrfleet, or one made by hand
  test::write_text(path, j.dump(1));
  const auto edited = io::read_posterior_file(path);
  CHECK(edited.weights[0] > cloud.weights[0]);
}

TEST_CASE("a posterior of several sites lists them and reads back, and a site list that does not fit its pool is refused",
          "[io][posterior][sites]") {
  test::TempDir dir;
  // 5 trucks in the pool. (The reader normalises the weights again: these 40 sum to exactly 1, so
  // they read back bit for bit, as in the first test.)
  auto cloud = random_cloud(40, 7, false);
  cloud.trucks_seen = 9;
  cloud.site_fingerprint = "sites:fa,fb";
  cloud.sites = {{"north", "fa", "AS1", 16, 0.0, 3.5, 6, 0, 3}, {"south", "fb", "AS2", 8, 0.2, 3.0, 3, 3, 2}};
  const std::string path = dir.file("p.json");
  write(path, cloud);
  const auto back = io::read_posterior_file(path);
  CHECK(same(back, cloud));
  REQUIRE(back.sites.size() == 2);
  for (std::size_t s = 0; s < 2; ++s) {
    const auto &a = back.sites[s], &b = cloud.sites[s];
    CHECK((a.name == b.name && a.fingerprint == b.fingerprint && a.road_name == b.road_name && a.sensors == b.sensors &&
           a.lateral_min_m == b.lateral_min_m && a.lateral_max_m == b.lateral_max_m && a.trucks_seen == b.trucks_seen &&
           a.pool_begin == b.pool_begin && a.pool_count == b.pool_count));
  }
  // One posterior file without sites has none.
  write(path, random_cloud(12, 5, false));
  CHECK(io::read_posterior_file(path).sites.empty());

  // Edits that a reader must refuse by field (written through the writer, so the checksum holds).
  const auto refused = [&](const std::function<void(fleet::PosteriorCloud&)>& edit, const std::string& field) {
    fleet::PosteriorCloud bad = cloud;
    edit(bad);
    write(path, bad);
    const auto e = test::data_error([&] { io::read_posterior_file(path); });
    REQUIRE(e);
    CHECK(e->field() == field);
    CHECK(std::string(e->what()).find(path) != std::string::npos);
  };
  refused([](auto& c) { c.sites[1].pool_begin = 2; }, "site.sites[1].pool");    // overlaps north's
  refused([](auto& c) { c.sites[1].pool_count = 3; }, "site.sites[1].pool");    // past the pool's end
  refused([](auto& c) { c.sites[1].pool_count = 1; }, "site.sites");            // a truck of no site
  refused([](auto& c) { c.sites[1].trucks_seen = 4; }, "site.sites[1].trucks_seen");  // 10 trucks, not 9
  refused([](auto& c) { c.sites[1].trucks_seen = 2; }, "site.sites");           // 8 trucks, not 9
  refused([](auto& c) { c.sites[1].name = "north"; }, "site.sites[1].name");    // two sites of one name
  refused([](auto& c) { c.sites[0].sensors = 0; }, "site.sites[0].sensors");
  refused([](auto& c) { c.sites.pop_back(); c.sites[0].pool_count = 5; c.sites[0].trucks_seen = 9; }, "site.sites");
  refused([](auto& c) { c.sites[1].trucks_seen = 0; }, "site.sites[1].pool");  // no trucks, yet a pool
  refused([](auto& c) { c.sites[0].trucks_seen = 10; }, "site.sites[0].trucks_seen");  // more than the file's

  // Values a writer never makes, edited in (the checksum taken out): refused by field, never cast.
  const auto edited = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& field) {
    write(path, cloud);
    auto j = nlohmann::json::parse(test::read_text(path));
    j.erase("checksum");
    edit(j);
    test::write_text(path, j.dump());
    const auto e = test::data_error([&] { io::read_posterior_file(path); });
    REQUIRE(e);
    CHECK(e->field() == field);
  };
  edited([](auto& j) { j["site"]["sites"][1]["pool"] = {3, 1e300}; }, "site.sites[1].pool.count");
  edited([](auto& j) { j["site"]["sites"][1]["pool"] = {2.9, 2}; }, "site.sites[1].pool.first");
  edited([](auto& j) { j["site"]["sites"][1]["pool"] = {3, -2}; }, "site.sites[1].pool.count");
  edited([](auto& j) { j["site"]["sites"][1]["pool"] = 3; }, "site.sites[1].pool");
  edited([](auto& j) { j["site"]["sites"][0]["trucks_seen"] = 4611686018427387904LL; }, "site.sites[0].trucks_seen");
}

TEST_CASE("a posterior file over the size limit is refused before it is parsed", "[io][posterior]") {
  test::TempDir dir;
  const std::string path = dir.file("huge.json");
  {
    std::ofstream out(path);
    out << "{";
  }
  std::filesystem::resize_file(path, io::kMaxPosteriorBytes + 1);  // sparse: no disk used
  const auto start = std::chrono::steady_clock::now();
  const auto e = test::data_error([&] { io::read_posterior_file(path); });
  REQUIRE(e);
  CHECK(e->field() == "size");
  CHECK(std::string(e->what()).find(path) != std::string::npos);
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(1));
}

TEST_CASE("a posterior pooled from final sweeps says how many, and a negative count is refused by name", "[io][posterior]") {
  test::TempDir dir;
  auto cloud = random_cloud(12, 5, false);
  cloud.pooled_sweeps = 3;  // 12 draws: 3 sweeps' copies of 4 particles
  const std::string path = dir.file("p.json");
  write(path, cloud);
  auto j = nlohmann::json::parse(test::read_text(path));
  CHECK(j["pooled_sweeps"] == 3);
  CHECK(j["particles"] == 12);
  CHECK(io::read_posterior_file(path).pooled_sweeps == 3);
  // A file without the field (written before pooling, or by the MCMC) holds no pool.
  cloud.pooled_sweeps = 0;
  write(path, cloud);
  CHECK_FALSE(nlohmann::json::parse(test::read_text(path)).contains("pooled_sweeps"));
  CHECK(io::read_posterior_file(path).pooled_sweeps == 0);
  j.erase("checksum");
  j["pooled_sweeps"] = -2;
  test::write_text(path, j.dump(1));
  const auto e = test::data_error([&] { io::read_posterior_file(path); });
  REQUIRE(e);
  CHECK(e->field() == "pooled_sweeps");
}

TEST_CASE("a posterior keeps its sites' sensor calibration, known or fitted, and refuses a bad one by name",
          "[io][posterior]") {
  test::TempDir dir;
  auto cloud = random_cloud(40, 7, false);  // the draws of the checksum test, which read back bit for bit
  cloud.calibration = {{"north", {1.0, 1.0625, 0.97}, {0.001, 0.0015, 0.002}}, {"south", {0.95, 1.0}, {}}};
  const std::string path = dir.file("p.json");
  write(path, cloud);
  const auto back = io::read_posterior_file(path);
  REQUIRE(back.calibration.size() == 2);
  CHECK(back.calibration[0].site == "north");
  CHECK(back.calibration[0].gain == cloud.calibration[0].gain);
  CHECK(back.calibration[0].se == cloud.calibration[0].se);
  CHECK(back.calibration[1].gain == cloud.calibration[1].gain);
  CHECK(back.calibration[1].se.empty());  // a known calibration has no standard errors
  CHECK(same(back, cloud));
  // Without a calibration the key is absent, and a file without it reads as none.
  cloud.calibration.clear();
  write(path, cloud);
  CHECK_FALSE(nlohmann::json::parse(test::read_text(path)).contains("calibration"));
  CHECK(io::read_posterior_file(path).calibration.empty());

  const auto refused = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& field) {
    cloud.calibration = {{"north", {1.0, 1.0625}, {0.001, 0.0015}}};
    write(path, cloud);
    auto j = nlohmann::json::parse(test::read_text(path));
    j.erase("checksum");
    edit(j);
    test::write_text(path, j.dump(1));
    const auto e = test::data_error([&] { io::read_posterior_file(path); });
    INFO(field);
    REQUIRE(e);
    CHECK(e->field() == field);
  };
  refused([](nlohmann::json& j) { j["calibration"] = nlohmann::json::array(); }, "calibration");
  refused([](nlohmann::json& j) { j["calibration"][0]["gain"][1] = 0.0; }, "calibration[0].gain");
  refused([](nlohmann::json& j) { j["calibration"][0]["gain"] = nlohmann::json::array(); }, "calibration[0].gain");
  refused([](nlohmann::json& j) { j["calibration"][0]["se"][0] = -0.1; }, "calibration[0].se");
  refused([](nlohmann::json& j) { j["calibration"][0]["se"] = {0.1}; }, "calibration[0].se");
  refused([](nlohmann::json& j) { j["calibration"][0].erase("site"); }, "calibration[0].site");
  refused([](nlohmann::json& j) { j["calibration"][0] = 3; }, "calibration[0]");
}

TEST_CASE("a posterior file's chain diagnostics read back, a file without them is one chain's, and a malformed one is "
          "refused by field",
          "[io][posterior]") {
  test::TempDir dir;
  auto cloud = random_cloud(8, 5, false);
  cloud.method = "mcmc";
  cloud.chains = 4;
  cloud.convergence = {{"K", 1.0123, 412.5, 301.25, 1021.5, 2048.25, 3001.125},
                       {"sigma_if", std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, 0.0, 0.0, 0.0}};
  const std::string path = dir.file("p.json");
  write(path, cloud);
  const auto back = io::read_posterior_file(path);
  CHECK(back.chains == 4);
  REQUIRE(back.convergence.size() == 2);
  const auto by_name = [&](const std::string& name) {
    return *std::find_if(back.convergence.begin(), back.convergence.end(),
                         [&](const fleet::ParameterConvergence& p) { return p.name == name; });
  };
  CHECK(by_name("K").rhat == 1.0123);
  CHECK(by_name("K").mcse_q95 == 3001.125);
  CHECK(std::isnan(by_name("sigma_if").rhat));  // written as null: no variation to measure

  auto j = nlohmann::json::parse(test::read_text(path));
  j.erase("checksum");
  auto refused_at = [&](nlohmann::json edited) {
    test::write_text(path, edited.dump(1));
    const auto e = test::data_error([&] { io::read_posterior_file(path); });
    return e ? e->field() : std::string("(read)");
  };
  nlohmann::json bad = j;
  bad["convergence"]["K"]["rhat"] = "high";
  CHECK(refused_at(bad) == "convergence.K.rhat");
  bad = j;
  bad["convergence"]["K"].erase("ess_tail");
  CHECK(refused_at(bad) == "convergence.K.ess_tail");
  bad = j;
  bad["chains"] = 0;
  CHECK(refused_at(bad) == "chains");
  bad = j;
  bad["convergence"] = 3;
  CHECK(refused_at(bad) == "convergence");
  // A file without them (one chain, an SMC run, an older ssrfleet) reads as one chain's.
  bad = j;
  bad.erase("chains");
  bad.erase("convergence");
  test::write_text(path, bad.dump(1));
  const auto plain = io::read_posterior_file(path);
  CHECK(plain.chains == 1);
  CHECK(plain.convergence.empty());
}

TEST_CASE("the weights' ESS and the MCMC's smallest ESS have their own names, and a file with the older ess reads",
          "[io][posterior]") {
  test::TempDir dir;
  const std::string path = dir.file("p.json");
  fleet::PosteriorCloud smc = random_cloud(40, 5, false);
  fleet::PosteriorCloud mcmc = random_cloud(40, 6, false);
  mcmc.method = "mcmc";
  mcmc.weights.setConstant(1.0 / 40.0);
  mcmc.weight_ess = 40.0;
  mcmc.min_ess = 12.5;
  for (const fleet::PosteriorCloud* c : {&smc, &mcmc}) {
    const bool is_mcmc = c->method == "mcmc";
    write(path, *c);
    nlohmann::json j = nlohmann::json::parse(test::read_text(path));
    CHECK(j.contains("weight_ess") == !is_mcmc);
    CHECK(j.contains("min_ess") == is_mcmc);
    CHECK(!j.contains("ess"));
    const fleet::PosteriorCloud back = io::read_posterior_file(path);
    CHECK(back.weight_ess == (is_mcmc ? 40.0 : smc.weight_ess));
    CHECK((is_mcmc ? back.min_ess == mcmc.min_ess : std::isnan(back.min_ess)));
    // As files held it before: one "ess", whose meaning was the method's (no checksum: such a file
    // still reads, and the edit would break one).
    const char* name = is_mcmc ? "min_ess" : "weight_ess";
    j["ess"] = j[name];
    j.erase(name);
    j.erase("checksum");
    test::write_text(path, j.dump(1));
    const fleet::PosteriorCloud old = io::read_posterior_file(path);
    CHECK((is_mcmc ? old.min_ess == mcmc.min_ess : old.weight_ess == smc.weight_ess));
  }
}
