// The posterior file's checksum (issue 20 item 4): a file cut short or with a byte changed is a
// DataError naming the file, never a wrong posterior; re-indenting it, or a file without a
// checksum, still reads.
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
  c.ess = 17.25;
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
         a.psi == b.psi && a.trucks_seen == b.trucks_seen && a.ess == b.ess && a.sensors == b.sensors;
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
          "[io][posterior]") {
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
