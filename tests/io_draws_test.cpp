// The draws files (docs/draws.md): equal-weight draws by systematic resampling at offset 1/2, the
// CSV read back against the posterior file's cloud, the NetCDF file read back through the C API,
// and the CLI's refusals (bad extension or path, malformed posterior, classes, several sites).
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "fleet/equal_weight_draws.hpp"
#include "fleet/posterior_summary.hpp"
#include "io/csv_reader.hpp"
#include "io/draws_csv.hpp"
#include "io/draws_netcdf.hpp"
#include "io/posterior_json.hpp"
#include "model/fleet_model.hpp"
#include "test_support.hpp"

#include <nlohmann/json.hpp>

using namespace ssrfleet;

namespace {

// A cloud of `columns` particles whose weights are whole multiples of 1 / (per-chain count), so
// each particle's number of draws is known exactly; theta's values use every digit of a double.
fleet::PosteriorCloud integer_weight_cloud(const std::string& method, int chains, int per_chain, unsigned seed,
                                           std::vector<int>* counts) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z(0.0, 1.0);
  fleet::PosteriorCloud c;
  c.method = method;
  c.chains = chains;
  const int columns = chains * per_chain;
  c.theta.resize(fleet::kHyperCount, columns);
  c.weights.resize(columns);
  counts->assign(static_cast<std::size_t>(columns), 0);
  for (int k = 0; k < chains; ++k) {
    // Deal per_chain draws among the chain's particles at random: many get 0, some several.
    std::uniform_int_distribution<int> pick(0, per_chain - 1);
    for (int i = 0; i < per_chain; ++i) ++(*counts)[static_cast<std::size_t>(k * per_chain + pick(rng))];
  }
  for (int i = 0; i < columns; ++i) {
    for (int h = 0; h < fleet::kHyperCount; ++h) c.theta(h, i) = 1e5 * (1.0 + 0.1 * z(rng)) / (h + 1);
    c.weights[i] = static_cast<double>((*counts)[static_cast<std::size_t>(i)]) / columns;
  }
  c.weights /= c.weights.sum();
  for (int t = 0; t < 4; ++t) {
    c.speed_mps.push_back(20.0 + t);
    c.sprung_mass_kg.push_back(5000.0 + 10.0 * t);
  }
  c.site_fingerprint = "0123456789abcdef";
  c.road_name = "AS1";
  c.sensors = 3;
  c.lateral_max_m = 5.0;
  c.trucks_seen = 4;
  c.log_evidence = method == "smc" ? -12.5 : NAN;
  c.weight_ess = 10.0;
  return c;
}

std::vector<int> draw_counts(const fleet::EqualWeightDraws& d, std::size_t columns) {
  std::vector<int> n(columns, 0);
  for (auto s : d.source) ++n[static_cast<std::size_t>(s)];
  return n;
}

}  // namespace

TEST_CASE("systematic draws at offset 1/2 give each particle of weight n/D exactly n draws", "[draws]") {
  std::mt19937_64 rng(5);
  for (int D : {1, 7, 64, 1000}) {
    std::vector<int> n(static_cast<std::size_t>(2 * D), 0);
    std::uniform_int_distribution<int> pick(0, 2 * D - 1);
    for (int i = 0; i < D; ++i) ++n[static_cast<std::size_t>(pick(rng))];
    Eigen::ArrayXd w(2 * D);
    for (int j = 0; j < 2 * D; ++j) w[j] = static_cast<double>(n[static_cast<std::size_t>(j)]) / (3.0 * D);  // unnormalised
    const auto picked = fleet::systematic_half_offset(w, D);
    REQUIRE(picked.size() == static_cast<std::size_t>(D));
    CHECK(std::is_sorted(picked.begin(), picked.end()));
    std::vector<int> got(n.size(), 0);
    for (auto j : picked) ++got[static_cast<std::size_t>(j)];
    CHECK(got == n);
  }
  // Equal weights: every particle once, in order.
  const auto identity = fleet::systematic_half_offset(Eigen::ArrayXd::Constant(9, 0.3), 9);
  for (std::size_t i = 0; i < identity.size(); ++i) CHECK(identity[i] == static_cast<Eigen::Index>(i));
  CHECK_THROWS_AS(fleet::systematic_half_offset(Eigen::ArrayXd::Zero(3), 3), std::invalid_argument);
  CHECK_THROWS_AS(fleet::systematic_half_offset(Eigen::ArrayXd::Constant(3, NAN), 3), std::invalid_argument);
}

TEST_CASE("equal-weight draws: MCMC chains and SMC runs stay apart, an SMC run's pooled sweeps are one chain", "[draws]") {
  std::vector<int> counts;
  fleet::PosteriorCloud mcmc = integer_weight_cloud("mcmc", 3, 50, 1, &counts);
  mcmc.weights = Eigen::ArrayXd::Constant(150, 1.0 / 150);
  const auto m = fleet::equal_weight_draws(mcmc);
  CHECK(m.chains == 3);
  CHECK(m.draws == 50);
  for (Eigen::Index i = 0; i < 150; ++i) CHECK(m.source[static_cast<std::size_t>(i)] == i);  // each draw once, in order
  CHECK(m.theta == mcmc.theta);

  // An SMC run's cloud of pooled sweeps: one chain, the pool resampled together.
  fleet::PosteriorCloud smc = integer_weight_cloud("smc", 1, 120, 2, &counts);
  smc.pooled_sweeps = 3;
  const auto s = fleet::equal_weight_draws(smc);
  CHECK(s.chains == 1);
  CHECK(s.draws == 120);
  CHECK(draw_counts(s, 120) == counts);
  for (Eigen::Index i = 0; i < 120; ++i) CHECK(s.theta.col(i) == smc.theta.col(s.source[static_cast<std::size_t>(i)]));

  // Independent SMC runs (fit --runs): each run its own chain, resampled within its block.
  fleet::PosteriorCloud runs = integer_weight_cloud("smc", 3, 40, 4, &counts);
  runs.chains = 3;
  const auto r = fleet::equal_weight_draws(runs);
  CHECK(r.chains == 3);
  CHECK(r.draws == 40);
  CHECK(draw_counts(r, 120) == counts);
  for (Eigen::Index i = 0; i < 120; ++i) CHECK(r.source[static_cast<std::size_t>(i)] / 40 == i / 40);

  // Chains that do not divide the draws are refused.
  mcmc.chains = 4;
  CHECK_THROWS_AS(fleet::equal_weight_draws(mcmc), std::invalid_argument);
}

TEST_CASE("the draws CSV reads back to the posterior file's cloud, bit for bit, with exact counts", "[draws][io]") {
  test::TempDir dir;
  std::vector<int> counts;
  fleet::PosteriorCloud cloud = integer_weight_cloud("mcmc", 2, 40, 3, &counts);
  cloud.model = "sensor_gain";
  cloud.psi_names = {"sensor", "gain"};
  cloud.psi.resize(2, 80);
  for (int i = 0; i < 80; ++i) cloud.psi.col(i) << 1.0 + i % 3, 1.0 + 1e-3 * i / 7.0;
  io::write_posterior_file(dir.file("p.json"), cloud, fleet::summarise_cloud(cloud), fleet::summarise_psi(cloud));
  const fleet::PosteriorCloud read = io::read_posterior_file(dir.file("p.json"));
  const auto draws = fleet::equal_weight_draws(read);
  REQUIRE(draws.chains == 2);
  CHECK(draw_counts(draws, 80) == counts);  // the JSON's normalised weights still give the whole counts
  std::ostringstream text;
  io::write_draws_csv(text, draws, read.psi_names);
  std::istringstream in(text.str());
  io::CsvReader csv(in, "draws.csv");
  io::CsvRow row;
  REQUIRE(csv.next(row));
  CHECK(row.fields == std::vector<std::string>{"chain", "draw", "K", "sigma_k", "Kt", "sigma_kt", "Z", "sigma_z",
                                               "sigma_if", "sensor", "gain"});
  Eigen::Index i = 0;
  while (csv.next(row)) {
    REQUIRE(row.fields.size() == 11);
    CHECK(row.fields[0] == std::to_string(i / 40));
    CHECK(row.fields[1] == std::to_string(i % 40));
    const Eigen::Index from = draws.source[static_cast<std::size_t>(i)];
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      CHECK(io::parse_finite(row.fields[static_cast<std::size_t>(2 + h)], "draws.csv", row.line, "x") == cloud.theta(h, from));
    }
    CHECK(io::parse_finite(row.fields[9], "draws.csv", row.line, "sensor") == cloud.psi(0, from));
    CHECK(io::parse_finite(row.fields[10], "draws.csv", row.line, "gain") == cloud.psi(1, from));
    ++i;
  }
  CHECK(i == 80);
}

TEST_CASE("the NetCDF draws file reads back through the C API: groups, dims, values, attributes", "[draws][io]") {
  test::TempDir dir;
  std::vector<int> counts;
  fleet::PosteriorCloud cloud = integer_weight_cloud("mcmc", 2, 30, 4, &counts);
  cloud.weights = Eigen::ArrayXd::Constant(60, 1.0 / 60);
  cloud.model = "tyre_damping";
  cloud.psi_names = {"ct"};
  cloud.psi = Eigen::MatrixXd::Constant(1, 60, 250.0);
  for (int p = 0; p < 8; ++p) {
    cloud.convergence.push_back({p < 7 ? std::string(fleet::kHyperNames[static_cast<std::size_t>(p)]) : "ct",
                                 1.0 + p * 1e-3, 100.0 + p, 90.0 + p, 0.1 * p, 0.2 * p, 0.3 * p});
  }
  std::vector<records::WimRecord> records(4);
  for (int t = 0; t < 4; ++t) {
    records[static_cast<std::size_t>(t)].truck_id = "T" + std::to_string(t);
    records[static_cast<std::size_t>(t)].speed_mps = 20.0 + t;
    records[static_cast<std::size_t>(t)].sprung_mass_kg = 5000.0 + t;
    Eigen::VectorXd y(3);
    y << 1.0 + t, 1.1 + t, 1.2 + t / 3.0;
    records[static_cast<std::size_t>(t)].impact_factor = y;
  }
  const auto draws = fleet::equal_weight_draws(cloud);
  const auto log = io::observed_log_of(records);
  const std::string path = dir.file("d.nc");
  io::write_draws_netcdf(path, cloud, draws, {io::iso_utc_now(), "9.9.9"}, &log);

  auto groups = io::netcdf_groups(path);
  std::sort(groups.begin(), groups.end());
  CHECK(groups == std::vector<std::string>{"constant_data", "observed_data", "posterior", "sample_stats"});
  // A posterior predictive of the wrong shape is a bug of the caller's.
  fleet::PosteriorPredictiveDraws wrong;
  wrong.draw_index = {0, 1};
  wrong.trucks = 4;
  wrong.impact_factor.resize(3, 3);
  CHECK_THROWS_AS(io::write_draws_netcdf(dir.file("w.nc"), cloud, draws, {"t", "v"}, &log, &wrong), std::invalid_argument);
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const auto v = io::read_netcdf_variable(path, "posterior", std::string(fleet::kHyperNames[static_cast<std::size_t>(h)]));
    CHECK(v.dims == std::vector<std::string>{"chain", "draw"});
    CHECK(v.shape == std::vector<std::size_t>{2, 30});
    for (int i = 0; i < 60; ++i) CHECK(v.values[static_cast<std::size_t>(i)] == cloud.theta(h, i));
  }
  CHECK(io::read_netcdf_variable(path, "posterior", "ct").values == std::vector<double>(60, 250.0));
  CHECK(io::read_netcdf_variable(path, "posterior", "chain").values == std::vector<double>{0, 1});
  const auto source = io::read_netcdf_variable(path, "sample_stats", "source_index");
  for (int i = 0; i < 60; ++i) CHECK(source.values[static_cast<std::size_t>(i)] == i);
  CHECK(io::read_netcdf_strings(path, "sample_stats", "parameter").back() == "ct");
  CHECK(io::read_netcdf_variable(path, "sample_stats", "ess_tail").values[3] == 93.0);
  const auto y = io::read_netcdf_variable(path, "observed_data", "if");
  CHECK(y.dims == std::vector<std::string>{"truck", "sensor"});
  CHECK(y.shape == std::vector<std::size_t>{4, 3});
  CHECK(y.values[3 * 2 + 2] == 1.2 + 2 / 3.0);
  CHECK(io::read_netcdf_strings(path, "observed_data", "truck") == std::vector<std::string>{"T0", "T1", "T2", "T3"});
  CHECK(io::read_netcdf_variable(path, "constant_data", "speed_mps").values[1] == 21.0);
  for (const auto& g : groups) {
    CHECK(io::read_netcdf_text_attribute(path, g, "inference_library") == "ssrfleet");
    CHECK(io::read_netcdf_text_attribute(path, g, "inference_library_version") == "9.9.9");
    CHECK(io::read_netcdf_text_attribute(path, g, "model_spec") == "tyre_damping");
    CHECK(std::regex_match(io::read_netcdf_text_attribute(path, g, "created_at"),
                           std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{6})")));
  }
  // Missing pieces are refused by file and field.
  const auto e = test::data_error([&] { io::read_netcdf_variable(path, "posterior", "nope"); });
  REQUIRE(e);
  CHECK(e->field() == "posterior/nope");
  CHECK(e->file() == path);
  test::write_text(dir.file("not.nc"), "hello");
  CHECK(test::data_error([&] { io::netcdf_groups(dir.file("not.nc")); }));
  CHECK_THROWS_AS(io::netcdf_groups(dir.file("missing.nc")), MissingInputError);
  // A directory that does not exist: IoError naming the path, nothing left behind.
  CHECK_THROWS_AS(io::write_draws_netcdf(dir.file("no/such/d.nc"), cloud, draws, {"t", "v"}), IoError);
}

namespace {
// A tiny fit for the CLI tests: 10 trucks, 64 particles, 2 pooled final sweeps (under a second).
struct TinyFit {
  test::TempDir dir;
  std::string log = dir.file("log.csv"), posterior = dir.file("p.json");
  TinyFit() {
    REQUIRE(test::run_ssrfleet("simulate --trucks 10 --seed 3 --out '" + log + "'", dir).status == 0);
    const auto r = test::run_ssrfleet("fit '" + log + "' --particles 64 --final-sweeps 2 -q --out '" + posterior +
                                          "' --draws-out '" + dir.file("fit.nc") + "'",
                                      dir);
    REQUIRE(r.status == 0);
  }
  bool leftovers() const {  // a temporary file or a partial output
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
      if (e.path().filename().string().find(".tmp.") != std::string::npos) return true;
    }
    return false;
  }
};
}  // namespace

TEST_CASE("ssrfleet draws and fit --draws-out write the draws, with the log as observed data", "[draws][cli]") {
  TinyFit f;
  CHECK(io::read_netcdf_variable(f.dir.file("fit.nc"), "observed_data", "if").shape == std::vector<std::size_t>{10, 16});
  CHECK(io::read_netcdf_variable(f.dir.file("fit.nc"), "posterior", "K").shape == std::vector<std::size_t>{1, 128});
  // draws of the same posterior with the same log: the same posterior values.
  const auto r = test::run_ssrfleet("draws '" + f.posterior + "' --log '" + f.log + "' --out '" + f.dir.file("d.nc") + "'", f.dir);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("1 chain x 128 draws") != std::string::npos);
  CHECK(io::read_netcdf_variable(f.dir.file("d.nc"), "posterior", "Z").values ==
        io::read_netcdf_variable(f.dir.file("fit.nc"), "posterior", "Z").values);
  // The posterior predictive: the cap's 100 draws of the one chain x the log's 10 trucks, the same
  // bits from fit and from draws for the same seed.
  const auto predictive = io::read_netcdf_variable(f.dir.file("fit.nc"), "posterior_predictive", "if");
  CHECK(predictive.dims == std::vector<std::string>{"chain", "draw", "truck", "sensor"});
  CHECK(predictive.shape == std::vector<std::size_t>{1, 100, 10, 16});
  CHECK(predictive.values == io::read_netcdf_variable(f.dir.file("d.nc"), "posterior_predictive", "if").values);
  const auto numbers = io::read_netcdf_variable(f.dir.file("fit.nc"), "posterior_predictive", "draw").values;
  CHECK(numbers[0] == 0.0);  // floor(0.5 x 128 / 100)
  CHECK(numbers[99] == 127.0);
  REQUIRE(test::run_ssrfleet("draws '" + f.posterior + "' -q --out '" + f.dir.file("d.csv") + "'", f.dir).status == 0);
  const std::string csv = test::read_text(f.dir.file("d.csv"));
  CHECK(std::count(csv.begin(), csv.end(), '\n') == 129);
  // --predictive-draws 0: no posterior_predictive; a fingerprint that is not the fit's is refused.
  REQUIRE(test::run_ssrfleet("draws '" + f.posterior + "' -q --log '" + f.log + "' --predictive-draws 0 --out '" +
                                 f.dir.file("o.nc") + "'",
                             f.dir)
              .status == 0);
  CHECK(io::netcdf_groups(f.dir.file("o.nc")).size() == 4);
  const auto other = test::run_ssrfleet("draws '" + f.posterior + "' -q --log '" + f.log + "' --road AS2 --out '" +
                                            f.dir.file("w.nc") + "'",
                                        f.dir);
  CHECK(other.status == 64);
  CHECK(other.err.find("--predictive-draws 0") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(f.dir.file("w.nc")));
  // Without --log: no observed_data.
  REQUIRE(test::run_ssrfleet("draws '" + f.posterior + "' -q --out '" + f.dir.file("n.nc") + "'", f.dir).status == 0);
  CHECK(io::netcdf_groups(f.dir.file("n.nc")).size() == 2);
}

TEST_CASE("draws refuses a bad extension, path, posterior or log by name, leaving no file", "[draws][cli]") {
  TinyFit f;
  auto r = test::run_ssrfleet("draws '" + f.posterior + "' --out '" + f.dir.file("x.txt") + "'", f.dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("--out") != std::string::npos);
  r = test::run_ssrfleet("fit '" + f.log + "' --particles 64 -q --out '" + f.dir.file("q.json") + "' --draws-out '" +
                             f.dir.file("x.json") + "'",
                         f.dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("--draws-out") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(f.dir.file("q.json")));  // refused before the fit
  r = test::run_ssrfleet("draws '" + f.posterior + "' --out '" + f.dir.file("no/dir/x.nc") + "'", f.dir);
  CHECK(r.status == 74);
  CHECK(r.err.find(f.dir.file("no/dir/x.nc")) != std::string::npos);
  r = test::run_ssrfleet("draws '" + f.posterior + "' --out '" + f.dir.file("no/dir/x.csv") + "'", f.dir);
  CHECK(r.status == 74);
  // A malformed posterior: the file and the field.
  auto j = nlohmann::json::parse(test::read_text(f.posterior));
  j.erase("checksum");
  j["cloud"]["weights"][3] = "heavy";
  test::write_text(f.dir.file("bad.json"), j.dump());
  r = test::run_ssrfleet("draws '" + f.dir.file("bad.json") + "' --out '" + f.dir.file("b.nc") + "'", f.dir);
  CHECK(r.status == 65);
  CHECK(r.err.find(f.dir.file("bad.json")) != std::string::npos);
  CHECK(r.err.find("weights") != std::string::npos);
  // A log that is not the fitted one (a truck short): the log and the field.
  std::string text = test::read_text(f.log);
  text.erase(text.rfind('\n', text.size() - 2) + 1);
  test::write_text(f.dir.file("short.csv"), text);
  r = test::run_ssrfleet("draws '" + f.posterior + "' --log '" + f.dir.file("short.csv") + "' --out '" +
                             f.dir.file("s.nc") + "'",
                         f.dir);
  CHECK(r.status == 65);
  CHECK(r.err.find("truck_id") != std::string::npos);
  for (const char* name : {"x.txt", "x.json", "b.nc", "s.nc"}) CHECK_FALSE(std::filesystem::exists(f.dir.file(name)));
  CHECK_FALSE(f.leftovers());
}

TEST_CASE("draws of vehicle classes: one class a file, chosen by --class, and several sites without observed data", "[draws][cli]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(test::run_ssrfleet("simulate --trucks 12 --seed 4 --out '" + log + "'", dir).status == 0);
  // Label the trucks A and B in turn.
  std::istringstream in(test::read_text(log));
  std::ostringstream out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    if (line.rfind('#', 0) == 0) {
      out << line << "\n";
    } else {
      out << line << "," << (n == 0 ? "class" : (n % 2 ? "A" : "B")) << "\n";
      ++n;
    }
  }
  test::write_text(dir.file("classes.csv"), out.str());
  const std::string fit = "fit '" + dir.file("classes.csv") + "' --particles 64 --final-sweeps 1 -q --out '" + dir.file("p.json") + "'";
  auto r = test::run_ssrfleet(fit + " --draws-out '" + dir.file("d.nc") + "'", dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("--class") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir.file("p.json")));
  REQUIRE(test::run_ssrfleet(fit, dir).status == 0);
  r = test::run_ssrfleet("draws '" + dir.file("p.json") + "' --out '" + dir.file("d.nc") + "'", dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("A, B") != std::string::npos);
  r = test::run_ssrfleet("draws '" + dir.file("p.json") + "' --class B --log '" + dir.file("classes.csv") + "' --out '" +
                             dir.file("b.nc") + "'",
                         dir);
  REQUIRE(r.status == 0);
  CHECK(io::read_netcdf_variable(dir.file("b.nc"), "observed_data", "if").shape == std::vector<std::size_t>{6, 16});
  CHECK(io::read_netcdf_strings(dir.file("b.nc"), "observed_data", "truck").front() == "T0002");
  // A fit of a manifest's sites together: --draws-out is refused before the fit (draws of the joint
  // posterior come from `draws`, without --log).
  r = test::run_ssrfleet("fit --sites '" + dir.file("manifest.json") + "' --draws-out '" + dir.file("s.nc") + "'", dir);
  CHECK(r.status == 64);
  CHECK(r.err.find("--draws-out") != std::string::npos);
}
