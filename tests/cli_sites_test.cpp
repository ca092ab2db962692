// Many sites fitted one by one: `fit --sites M --site NAME`, `sites`
// (check, --names, --collect), scripts/fit-sites.sh (GNU parallel) and scripts/fit-sites.sbatch
// (a Slurm array task), and a bad manifest entry named by manifest, site and field.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "fleet/joint_sites.hpp"
#include "fleet/posterior_summary.hpp"
#include "io/csv_reader.hpp"
#include "io/posterior_json.hpp"
#include "io/site_manifest.hpp"
#include "model/fleet_model.hpp"
#include "gained_log.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

// Two sites on different roads and sensor arrays, 24 trucks each.
struct TwoSites {
  test::TempDir dir;
  std::string manifest = dir.file("m.json");
  TwoSites() {
    REQUIRE(run_ssrfleet("simulate --road AS1 --trucks 24 --seed 3 --quiet --out " + q(dir.file("a.csv")), dir).status == 0);
    REQUIRE(run_ssrfleet("simulate --road AS2 --sensors 70,2,8 --trucks 24 --seed 4 --quiet --out " + q(dir.file("b.csv")), dir)
                .status == 0);
    write_manifest("76,1.5,16");
  }
  void write_manifest(const std::string& north_sensors) const {
    test::write_text(manifest, R"({"sites": [
        {"name": "north", "road": "AS1", "sensors": ")" + north_sensors + R"(", "log": "a.csv"},
        {"name": "south", "road": "AS2", "sensors": "70,2,8", "log": "b.csv"}]})");
  }
};

// Runs a script of the repository with `env` before it; its exit status and its stderr.
test::RunResult run_script(const std::string& env, const std::string& script, const std::string& args,
                           const test::TempDir& dir) {
  const std::string err = dir.file("script-stderr.txt");
  const std::string cmd = env + " SSRFLEET=" + q(SSRFLEET_BINARY) + " bash " + q(std::string(SSRFLEET_SOURCE_DIR) + "/" + script) +
                          " " + args + " >/dev/null 2>" + q(err) + " </dev/null";
  const int raw = std::system(cmd.c_str());
  test::RunResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.err = test::read_text(err);
  return r;
}
}  // namespace

TEST_CASE("fit --sites M --site NAME gives the very posterior of fit with that site's log, road and sensors",
          "[cli][sites][heavy]") {
  TwoSites s;
  const auto via_manifest = run_ssrfleet("fit --sites " + q(s.manifest) + " --site south --particles 64 --seed 3 --quiet --out " +
                                             q(s.dir.file("m-south.json")),
                                         s.dir);
  INFO(via_manifest.err);
  REQUIRE(via_manifest.status == 0);
  REQUIRE(run_ssrfleet("fit " + q(s.dir.file("b.csv")) + " --road AS2 --sensors 70,2,8 --particles 64 --seed 3 --quiet --out " +
                           q(s.dir.file("plain-south.json")),
                       s.dir)
              .status == 0);
  CHECK(test::read_text(s.dir.file("m-south.json")) == test::read_text(s.dir.file("plain-south.json")));
  CHECK(io::read_posterior_file(s.dir.file("m-south.json")).sensors == 8);

  // Options that do not go together, each a usage error that says why.
  const auto usage = [&](const std::string& args, const std::string& says) {
    const auto r = run_ssrfleet("fit " + args + " --particles 64 --quiet --out " + q(s.dir.file("x.json")), s.dir);
    INFO(args << ": " << r.err);
    CHECK(r.status == 64);
    CHECK(r.err.find(says) != std::string::npos);
  };
  usage("--sites " + q(s.manifest) + " --method mcmc", "--site NAME");
  usage("--sites " + q(s.manifest) + " --core latent", "marginal core");
  usage("--sites " + q(s.manifest) + " --model tyre_damping", "--site NAME");
  usage("--site south", "--sites");
  usage("--sites " + q(s.manifest) + " --site south --road AS1", "--road with --sites");
  usage("--sites " + q(s.manifest) + " --site east", "north, south");
  usage("", "LOG, or --sites");
}

TEST_CASE("fit --sites M fits one fleet from every site, and predict --sites M --site NAME predicts a site with its "
          "own traffic",
          "[cli][sites][heavy]") {
  TwoSites s;
  const std::string joint = s.dir.file("joint.json");
  const auto fit = run_ssrfleet("fit --sites " + q(s.manifest) + " --particles 64 --seed 3 --quiet --out " + q(joint), s.dir);
  INFO(fit.err);
  REQUIRE(fit.status == 0);
  const fleet::PosteriorCloud cloud = io::read_posterior_file(joint);
  CHECK(cloud.trucks_seen == 48);
  REQUIRE(cloud.sites.size() == 2);
  CHECK(cloud.sites[0].name == "north");
  CHECK(cloud.sites[1].name == "south");
  CHECK(cloud.sites[1].sensors == 8);
  CHECK(cloud.sites[1].road_name == "AS2");
  CHECK(cloud.sites[1].trucks_seen == 24);
  CHECK(cloud.sites[1].pool_begin == 24);
  CHECK(cloud.sites[1].pool_count == 24);
  CHECK(cloud.road_name == "AS1+AS2");

  // At a site: the joint θ, that site's own speeds and masses; the very prediction of a posterior
  // file holding just that (cloud_at_site) on that site's road and sensors.
  const std::string at_south = s.dir.file("south.csv"), by_hand = s.dir.file("hand.csv");
  const auto predicted = run_ssrfleet("predict --posterior " + q(joint) + " --sites " + q(s.manifest) +
                                          " --site south --draws 20 --trucks-per-draw 20 --quiet --out " + q(at_south),
                                      s.dir);
  INFO(predicted.err);
  REQUIRE(predicted.status == 0);
  const fleet::PosteriorCloud south = fleet::cloud_at_site(cloud, 1);
  CHECK(south.speed_mps.size() == 24);
  io::write_posterior_file(s.dir.file("south.json"), south, fleet::summarise_cloud(south));
  REQUIRE(run_ssrfleet("predict --posterior " + q(s.dir.file("south.json")) +
                           " --road AS2 --sensors 70,2,8 --draws 20 --trucks-per-draw 20 --quiet --out " + q(by_hand),
                       s.dir)
              .status == 0);
  const std::string text = test::read_text(at_south);
  CHECK(std::count(text.begin(), text.end(), '\n') == 9);  // a header and the 8 sensors
  CHECK(text == test::read_text(by_hand));

  const auto usage = [&](const std::string& args, const std::string& says) {
    const auto r = run_ssrfleet("predict --posterior " + q(joint) + " " + args + " --quiet --out " + q(s.dir.file("x.csv")),
                                s.dir);
    INFO(args << ": " << r.err);
    CHECK(r.status == 64);
    CHECK(r.err.find(says) != std::string::npos);
  };
  usage("--road AS1", "--sites MANIFEST --site NAME");  // the joint posterior is no one road's
  usage("--sites " + q(s.manifest), "--site NAME");
  usage("--site south", "--sites");
  usage("--sites " + q(s.manifest) + " --site south --road AS2", "--road with --sites");
  usage("--sites " + q(s.manifest) + " --site east", "north, south");
  // Another road on purpose: every site's traffic.
  CHECK(run_ssrfleet("predict --posterior " + q(joint) + " --road AS3 --new-road --draws 10 --trucks-per-draw 10 --quiet "
                     "--out " + q(s.dir.file("new.csv")),
                     s.dir)
            .status == 0);

  // damage and weigh take a site of a joint posterior the same way.
  const auto damage = run_ssrfleet("damage --posterior " + q(joint) + " --sites " + q(s.manifest) +
                                       " --site south --draws 10 --trucks-per-draw 10 --quiet --out " +
                                       q(s.dir.file("damage.csv")),
                                   s.dir);
  INFO(damage.err);
  CHECK(damage.status == 0);
  REQUIRE(run_ssrfleet("simulate --road AS2 --sensors 70,2,8 --trucks 3 --seed 9 --forces --quiet --out " +
                           q(s.dir.file("forces.csv")),
                       s.dir)
              .status == 0);
  const auto weighed = run_ssrfleet("weigh " + q(s.dir.file("forces.csv")) + " --posterior " + q(joint) + " --sites " +
                                        q(s.manifest) + " --site south --draws 10 --trucks-per-draw 10 --quiet",
                                    s.dir);
  INFO(weighed.err);
  CHECK(weighed.status == 0);
  CHECK(std::count(weighed.out.begin(), weighed.out.end(), '\n') == 4);  // a header and 3 trucks
  const auto not_one_road = run_ssrfleet("weigh " + q(s.dir.file("forces.csv")) + " --posterior " + q(joint) +
                                             " --road AS2 --sensors 70,2,8 --quiet",
                                         s.dir);
  CHECK(not_one_road.status == 64);
  CHECK(not_one_road.err.find("fitted on several sites") != std::string::npos);
  CHECK(not_one_road.err.find("--sites MANIFEST --site NAME") != std::string::npos);

  // A bad record in one site's log: the file, line and field, with the site and the manifest.
  std::string b = test::read_text(s.dir.file("b.csv"));
  const std::size_t line3 = b.find('\n', b.find('\n') + 1) + 1;
  b.insert(line3, "BAD,1,x\n");
  test::write_text(s.dir.file("b.csv"), b);
  const auto bad = run_ssrfleet("fit --sites " + q(s.manifest) + " --particles 64 --quiet --out " + q(joint), s.dir);
  INFO(bad.err);
  CHECK(bad.status == 65);
  CHECK(bad.err.find(s.dir.file("b.csv") + ":3: field") != std::string::npos);
  CHECK(bad.err.find("site 'south' of manifest '" + s.manifest + "'") != std::string::npos);
}

TEST_CASE("a manifest's site whose road does not cover its sensors, or whose log has other sensors, is named",
          "[cli][sites]") {
  TwoSites s;
  // 40 sensors from 76 m at 1.5 m end at 134.5 m, past AS1's end.
  s.write_manifest("76,1.5,40");
  for (const std::string& command : {"sites " + q(s.manifest), "fit --sites " + q(s.manifest) + " --site north --quiet"}) {
    const auto r = run_ssrfleet(command, s.dir);
    INFO(command << ": " << r.err);
    CHECK(r.status == 65);
    CHECK(r.err.find(s.manifest) != std::string::npos);
    CHECK(r.err.find("sites[0].sensors") != std::string::npos);
    CHECK(r.err.find("site 'north'") != std::string::npos);
    CHECK(r.err.find("beyond the road's end") != std::string::npos);
    CHECK(r.out.empty());  // no table of the sites that did pass
  }
  // A sensor array the road covers, but the log has 16 sensors and the manifest says 8.
  s.write_manifest("76,1.5,8");
  const auto r = run_ssrfleet("sites " + q(s.manifest), s.dir);
  INFO(r.err);
  CHECK(r.status == 65);
  CHECK(r.err.find(s.dir.file("a.csv")) != std::string::npos);  // the log, with its line and field
  CHECK(r.err.find("if_16") != std::string::npos);
  CHECK(r.err.find("site 'north' of manifest '" + s.manifest + "'") != std::string::npos);
  // A malformed sensor array.
  s.write_manifest("76;1.5;16");
  const auto bad = run_ssrfleet("sites " + q(s.manifest), s.dir);
  CHECK(bad.status == 65);
  CHECK(bad.err.find("sites[0].sensors") != std::string::npos);
}

TEST_CASE("scripts/fit-sites.sh fits every site alone with GNU parallel and collects one table, and a Slurm task fits one",
          "[cli][sites][heavy]") {
  TwoSites s;
  const std::string out = s.dir.file("out");
  const auto run = run_script("JOBS=2 THREADS=1", "scripts/fit-sites.sh", q(s.manifest) + " " + q(out) + " --particles 64 --seed 3",
                              s.dir);
  INFO(run.err);
  REQUIRE(run.status == 0);
  // The table: one row per site and hyperparameter, each the summary of that site's posterior file.
  std::istringstream table(test::read_text(out + "/sites.csv"));
  io::CsvReader csv(table, out + "/sites.csv");
  io::CsvRow row;
  REQUIRE(csv.next(row));
  const std::vector<std::string> header = row.fields;
  const auto column = [&](const char* name) {
    const long c = io::column_index(header, name);
    REQUIRE(c >= 0);
    return static_cast<std::size_t>(c);
  };
  std::map<std::string, int> rows;
  while (csv.next(row)) {
    const std::vector<std::string>& f = row.fields;
    const std::string site = f[column("site")];
    const auto cloud = io::read_posterior_file(out + "/" + site + ".json");
    const auto summary = fleet::summarise_cloud(cloud);
    const std::string name = f[column("parameter")];
    const int h = rows[site]++;
    REQUIRE(h < fleet::kHyperCount);
    CHECK(name == fleet::kHyperNames[static_cast<std::size_t>(h)]);
    CHECK(std::stol(f[column("trucks")]) == 24);
    CHECK(std::stod(f[column("mean")]) == Approx(summary[static_cast<std::size_t>(h)].mean).epsilon(1e-9));
    CHECK(std::stod(f[column("q975")]) == Approx(summary[static_cast<std::size_t>(h)].q975).epsilon(1e-9));
  }
  CHECK(rows == std::map<std::string, int>{{"north", fleet::kHyperCount}, {"south", fleet::kHyperCount}});
  // The two sites' fleets are fitted on their own roads: AS2's posterior is not AS1's.
  CHECK(io::read_posterior_file(out + "/south.json").road_name == "AS2");

  // Slurm: array task 1 is the second site, the same posterior bits as the parallel run's.
  const std::string out2 = s.dir.file("out2");
  const auto task = run_script("SLURM_ARRAY_TASK_ID=1 SLURM_CPUS_PER_TASK=2", "scripts/fit-sites.sbatch",
                               q(s.manifest) + " " + q(out2) + " --particles 64 --seed 3 --quiet", s.dir);
  INFO(task.err);
  REQUIRE(task.status == 0);
  CHECK(test::read_text(out2 + "/south.json") == test::read_text(out + "/south.json"));
  CHECK_FALSE(std::filesystem::exists(out2 + "/north.json"));
  CHECK(run_script("SLURM_ARRAY_TASK_ID=2", "scripts/fit-sites.sbatch", q(s.manifest) + " " + q(out2), s.dir).status == 64);

  // A posterior of another site under a site's name is refused by --collect, naming the site.
  std::filesystem::copy_file(out + "/north.json", out + "/south.json", std::filesystem::copy_options::overwrite_existing);
  const auto mixed = run_ssrfleet("sites " + q(s.manifest) + " --collect " + q(out), s.dir);
  CHECK(mixed.status == 64);
  CHECK(mixed.err.find("site 'south'") != std::string::npos);
  std::filesystem::remove(out + "/south.json");
  const auto missing = run_ssrfleet("sites " + q(s.manifest) + " --collect " + q(out), s.dir);
  CHECK(missing.status == 66);
  CHECK(missing.err.find("--site south") != std::string::npos);  // how to make it

  // A bad entry stops the script before any fit runs.
  s.write_manifest("76,1.5,40");
  const std::string out3 = s.dir.file("out3");
  const auto refused = run_script("JOBS=1", "scripts/fit-sites.sh", q(s.manifest) + " " + q(out3) + " --particles 64", s.dir);
  CHECK(refused.status == 65);
  CHECK(refused.err.find("sites[0].sensors") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(out3 + "/south.json"));
}

TEST_CASE("a manifest may leave its logs out for a stream, and fit and sites then name the missing log",
          "[cli][sites]") {
  test::TempDir dir;
  const std::string manifest = dir.file("m.json");
  test::write_text(manifest, R"({"sites": [
      {"name": "north", "road": "AS1", "sensors": "76,1.5,16"},
      {"name": "south", "road": "AS2", "sensors": "70,2,8"}]})");
  const auto listed = run_ssrfleet("sites " + q(manifest) + " --quiet", dir);
  INFO(listed.err);
  REQUIRE(listed.status == 0);
  CHECK(listed.out.find("south,\"AS2\",\"70,2,8\",,\"\"") != std::string::npos);  // no trucks, no log
  for (const std::string& command : {"fit --sites " + q(manifest), "fit --sites " + q(manifest) + " --site south"}) {
    const auto r = run_ssrfleet(command + " --particles 64 --quiet --out " + q(dir.file("p.json")), dir);
    INFO(command << ": " << r.err);
    CHECK(r.status == 65);
    CHECK(r.err.find(manifest) != std::string::npos);
    CHECK(r.err.find(command.find("--site south") != std::string::npos ? "sites[1].log" : "sites[0].log") !=
          std::string::npos);
    CHECK(r.err.find("a fit reads each site's log") != std::string::npos);
  }
}

TEST_CASE("sites --check writes a row per site with its conflict p-value and names no site of one fleet",
          "[cli][sites][conflict][heavy]") {
  TwoSites s;
  REQUIRE(run_ssrfleet("simulate --road AS3 --sensors 60,1.5,12 --trucks 24 --seed 5 --quiet --out " + q(s.dir.file("c.csv")),
                       s.dir)
              .status == 0);
  test::write_text(s.manifest, R"({"sites": [
      {"name": "north", "road": "AS1", "sensors": "76,1.5,16", "log": "a.csv"},
      {"name": "south", "road": "AS2", "sensors": "70,2,8", "log": "b.csv"},
      {"name": "east", "road": "AS3", "sensors": "60,1.5,12", "log": "c.csv"}]})");
  const auto r = run_ssrfleet("sites " + q(s.manifest) + " --check --particles 128 --threads 2 --seed 4 --quiet", s.dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  std::istringstream table(r.out);
  io::CsvReader csv(table, "check.csv");
  io::CsvRow row;
  REQUIRE(csv.next(row));
  const auto header = row.fields;
  CHECK(header.size() == 6 + 7 * 4);
  const auto p_col = static_cast<std::size_t>(io::column_index(header, "p_value"));
  const auto flag_col = static_cast<std::size_t>(io::column_index(header, "flagged"));
  std::vector<std::string> sites;
  while (csv.next(row)) {
    sites.push_back(row.fields[0]);
    const double p = std::stod(row.fields[p_col]);
    CHECK((p > 0.0 && p <= 1.0));
    CHECK(row.fields[flag_col] == "no");
  }
  CHECK(sites == std::vector<std::string>{"north", "south", "east"});
  CHECK(r.err.find("no site's fleet differs") != std::string::npos);

  const auto both = run_ssrfleet("sites " + q(s.manifest) + " --check --names", s.dir);
  CHECK(both.status == 64);
  test::write_text(s.manifest, R"({"sites": [{"name": "north", "road": "AS1", "sensors": "76,1.5,16", "log": "a.csv"}]})");
  const auto one = run_ssrfleet("sites " + q(s.manifest) + " --check --quiet", s.dir);
  CHECK(one.status == 64);
  CHECK(one.err.find("has one site") != std::string::npos);
}

using test::write_gained_log;

TEST_CASE("a manifest's known sensor calibration is divided out of its site's records before the fit",
          "[cli][sites][calibration][heavy]") {
  TwoSites s;
  // Gains of 2 and 0.5 multiply and divide a double exactly: the corrected log is the clean log's bits.
  std::vector<double> north(16, 1.0);
  north[4] = 2.0;
  north[9] = 0.5;
  write_gained_log(s.dir.file("a.csv"), s.dir.file("a-gained.csv"), north);
  const std::string clean = s.dir.file("clean.json"), corrected = s.dir.file("corrected.json");
  REQUIRE(run_ssrfleet("fit --sites " + q(s.manifest) + " --particles 64 --seed 3 --quiet --out " + q(clean), s.dir).status == 0);
  const auto manifest_with = [&](const std::string& calibration) {
    test::write_text(s.manifest, R"({"sites": [
        {"name": "north", "road": "AS1", "sensors": "76,1.5,16", "log": "a-gained.csv", "calibration": )" + calibration + R"(},
        {"name": "south", "road": "AS2", "sensors": "70,2,8", "log": "b.csv"}]})");
  };
  manifest_with("[1,1,1,1,2,1,1,1,1,0.5,1,1,1,1,1,1]");
  const auto r = run_ssrfleet("fit --sites " + q(s.manifest) + " --particles 64 --seed 3 --quiet --out " + q(corrected), s.dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  const auto a = io::read_posterior_file(clean), b = io::read_posterior_file(corrected);
  CHECK(a.theta == b.theta);
  CHECK((a.weights == b.weights).all());
  CHECK(a.calibration.empty());
  REQUIRE(b.calibration.size() == 2);
  CHECK(b.calibration[0].site == "north");
  CHECK(b.calibration[0].gain == north);
  CHECK(b.calibration[0].se.empty());  // known, not fitted
  CHECK(b.calibration[1].gain == std::vector<double>(8, 1.0));
  // The same site fitted alone through the manifest is corrected too, and says so.
  const std::string alone = s.dir.file("alone.json");
  REQUIRE(run_ssrfleet("fit --sites " + q(s.manifest) + " --site north --particles 64 --seed 3 --quiet --out " + q(alone), s.dir)
              .status == 0);
  const std::string plain = s.dir.file("plain.json");
  REQUIRE(run_ssrfleet("fit " + q(s.dir.file("a.csv")) + " --particles 64 --seed 3 --quiet --out " + q(plain), s.dir).status == 0);
  CHECK(io::read_posterior_file(alone).theta == io::read_posterior_file(plain).theta);
  CHECK(io::read_posterior_file(alone).calibration.size() == 1);

  // weigh divides the posterior's calibration of the site out of the forces: the gained forces
  // weighed with the calibrated posterior give the clean forces' weights with the clean posterior.
  REQUIRE(run_ssrfleet("simulate --road AS1 --trucks 3 --seed 9 --forces --quiet --out " + q(s.dir.file("forces.csv")), s.dir)
              .status == 0);
  write_gained_log(s.dir.file("forces.csv"), s.dir.file("forces-gained.csv"), north, "force_");
  const auto weigh = [&](const std::string& forces, const std::string& posterior) {
    const auto w = run_ssrfleet("weigh " + q(forces) + " --posterior " + q(posterior) + " --sites " + q(s.manifest) +
                                    " --site north --draws 10 --trucks-per-draw 10 --quiet",
                                s.dir);
    INFO(w.err);
    CHECK(w.status == 0);
    return w.out;
  };
  const std::string calibrated_manifest = test::read_text(s.manifest);
  s.write_manifest("76,1.5,16");  // the same sites without a calibration
  const std::string clean_weights = weigh(s.dir.file("forces.csv"), clean);
  CHECK(std::count(clean_weights.begin(), clean_weights.end(), '\n') == 4);
  CHECK(weigh(s.dir.file("forces-gained.csv"), clean) != clean_weights);
  test::write_text(s.manifest, calibrated_manifest);
  CHECK(weigh(s.dir.file("forces-gained.csv"), corrected) == clean_weights);
  // A manifest that calibrates the site beside a posterior fitted without: the forces would be
  // corrected and the fleet not.
  const auto mixed = run_ssrfleet("weigh " + q(s.dir.file("forces-gained.csv")) + " --posterior " + q(clean) + " --sites " +
                                      q(s.manifest) + " --site north --draws 10 --trucks-per-draw 10 --quiet",
                                  s.dir);
  CHECK(mixed.status == 64);
  CHECK(mixed.err.find("fitted without one") != std::string::npos);

  // A calibration of another sensor count is named by manifest, site and field.
  manifest_with("[1, 1.02]");
  const auto bad = run_ssrfleet("fit --sites " + q(s.manifest) + " --particles 64 --quiet --out " + q(s.dir.file("x.json")), s.dir);
  CHECK(bad.status == 65);
  CHECK(bad.err.find(s.manifest) != std::string::npos);
  CHECK(bad.err.find("sites[0].calibration") != std::string::npos);
  CHECK(bad.err.find("site 'north'") != std::string::npos);
  CHECK(bad.err.find("2 gains for 16 sensors") != std::string::npos);
}

TEST_CASE("fit --sites --calibrate fits every site's sensor gains and records them with standard errors",
          "[cli][sites][calibration][heavy]") {
  TwoSites s;
  const std::string out = s.dir.file("cal.json");
  const std::string written = s.dir.file("calibrated/m.json");
  std::filesystem::create_directories(s.dir.file("calibrated"));
  const auto r = run_ssrfleet("fit --sites " + q(s.manifest) + " --calibrate --calibration-rounds 2 --particles 64 --seed 3 --out " +
                                  q(out) + " --write-manifest " + q(written),
                              s.dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("calibration round 1: largest gain step") != std::string::npos);
  CHECK(r.err.find("site south sensor gains:") != std::string::npos);
  const auto cloud = io::read_posterior_file(out);
  REQUIRE(cloud.calibration.size() == 2);
  CHECK(cloud.calibration[0].gain.size() == 16);
  REQUIRE(cloud.calibration[1].se.size() == 8);
  for (const auto& c : cloud.calibration) {
    for (std::size_t j = 0; j < c.gain.size(); ++j) {
      // Clean logs of 24 trucks: every gain is 1 within a few of its standard errors (about 0.006).
      CHECK(c.se[j] > 0.0);
      CHECK(c.se[j] < 0.02);
      CHECK(std::abs(c.gain[j] - 1.0) < 5.0 * c.se[j]);
    }
  }
  // The manifest written again, in another folder, with the fitted gains: a stream's starting point.
  const io::SiteManifest again = io::read_site_manifest(written);
  REQUIRE(again.sites.size() == 2);
  for (std::size_t k = 0; k < 2; ++k) CHECK(again.sites[k].calibration == cloud.calibration[k].gain);
  CHECK(again.sites[0].road == "AS1");
  CHECK(again.sites[1].sensors == "70,2,8");
  CHECK(again.sites[0].log == s.dir.file("a.csv"));  // absolute, so it still names the log
  const auto usage = [&](const std::string& args, const std::string& says) {
    const auto u = run_ssrfleet("fit " + args + " --particles 64 --quiet --out " + q(s.dir.file("x.json")), s.dir);
    INFO(args << ": " << u.err);
    CHECK(u.status == 64);
    CHECK(u.err.find(says) != std::string::npos);
  };
  usage("--sites " + q(s.manifest) + " --write-manifest " + q(s.dir.file("w.json")), "add --calibrate");
  usage("--sites " + q(s.manifest) + " --site north --write-manifest " + q(s.dir.file("w.json")), "add --calibrate");
  usage("--sites " + q(s.manifest) + " --calibration-rounds 3", "needs --calibrate");
  usage("--sites " + q(s.manifest) + " --site north --calibrate", "drop --site");
  usage(q(s.dir.file("a.csv")) + " --calibrate", "needs --sites");
  usage("--sites " + q(s.manifest) + " --calibrate --checkpoint " + q(s.dir.file("ck")), "--checkpoint with --calibrate");
  usage("--sites " + q(s.manifest) + " --calibrate --calibration-rounds 0", "--calibration-rounds");
}
