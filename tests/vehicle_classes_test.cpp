// Vehicle classes: the class column, a posterior per class, mixtures by traffic
// share in predict and damage, class-labelled streams, mixed fleets in simulate.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "damage/damage_profile.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/csv_reader.hpp"
#include "io/history_db.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "model/fleet_model.hpp"
#include "predict/ssr_prediction.hpp"
#include "site/road_source.hpp"
#include "test_support.hpp"
#include "util/quantile.hpp"

using namespace ssrfleet;
using test::run_ssrfleet;

namespace {
std::string q(const std::string& p) { return "'" + p + "'"; }

// The class column of a WIM log or truck list, in order.
std::vector<std::string> class_column(const std::string& path) {
  std::ifstream in(path);
  io::CsvReader csv(in, path);
  io::CsvRow row;
  REQUIRE(csv.next(row));
  const long c = io::column_index(row.fields, "class");
  REQUIRE(c >= 0);
  std::vector<std::string> out;
  while (csv.next(row)) out.push_back(row.fields[static_cast<std::size_t>(c)]);
  return out;
}

// Two classes whose suspensions differ by far more than a 40-truck posterior's sd (about 6e3 N/m).
const char* kTwoClasses = "A:share=0.5,k-mean=350e3,k-sd=30e3;B:share=0.5,k-mean=650e3,k-sd=30e3";

// A 24-truck two-class log and its fit (128 particles), made once and shared by the predict,
// damage and weigh tests (which only read it).
struct TwoClassFit {
  test::TempDir dir;
  std::string log = dir.file("log.csv"), post = dir.file("post.json");
  TwoClassFit() {
    REQUIRE(run_ssrfleet(std::string("simulate --trucks 24 --seed 11 --quiet --fleet-mix '") + kTwoClasses + "' --out " + q(log),
                         dir).status == 0);
    const auto fit = run_ssrfleet("fit " + q(log) + " --particles 128 --final-sweeps 3 --seed 5 --quiet --out " + q(post), dir);
    INFO(fit.err);
    REQUIRE(fit.status == 0);
  }
};

const TwoClassFit& two_class_fit() {
  static const TwoClassFit fit;
  return fit;
}
}  // namespace

TEST_CASE("the WIM log's class column is read, written back and checked", "[io][classes]") {
  const std::string text =
      "truck_id,class,speed_mps,sprung_mass_kg,if_1\nT1,9,20,4000,1.0\nT2,truck_B.x-1,21,4100,1.01\nT3,bad label,20,4000,1\n";
  std::istringstream in(text);
  io::WimLogReader reader(in, "log.csv", 420.0);
  CHECK(reader.has_classes());
  records::WimRecord r;
  io::Rejection why;
  REQUIRE(reader.next(r, why) == io::WimLogReader::Status::record);
  CHECK(r.vehicle_class == "9");
  REQUIRE(reader.next(r, why) == io::WimLogReader::Status::record);
  CHECK(r.vehicle_class == "truck_B.x-1");
  REQUIRE(reader.next(r, why) == io::WimLogReader::Status::rejected);
  CHECK(why.line == 4);
  CHECK(why.field == "class");
  CHECK(why.message.find("log.csv:4") != std::string::npos);

  test::TempDir dir;
  SECTION("a bad label is a DataError naming file, line and field") {
    const std::string path = dir.file("bad.csv");
    test::write_text(path, "truck_id,speed_mps,sprung_mass_kg,if_1,class\nT1,20,4000,1.0,A\nT2,20,4000,1.0,\n");
    const auto e = test::data_error([&] { io::read_wim_log_file(path, 420.0); });
    REQUIRE(e.has_value());
    CHECK(e->line() == 3);
    CHECK(e->field() == "class");
    CHECK(std::string(e->what()).find(path) != std::string::npos);
  }
  SECTION("FHWA classes only, when asked") {
    const std::string path = dir.file("fhwa.csv");
    test::write_text(path, "truck_id,speed_mps,sprung_mass_kg,if_1,class\nT1,20,4000,1.0,13\nT2,20,4000,1.0,14\n");
    io::WimLimits fhwa;
    fhwa.fhwa_classes = true;
    const auto e = test::data_error([&] { io::read_wim_log_file(path, 420.0, nullptr, fhwa); });
    REQUIRE(e.has_value());
    CHECK(e->line() == 3);
    CHECK(e->field() == "class");
    CHECK(io::read_wim_log_file(path, 420.0).size() == 2);  // any label otherwise
  }
  SECTION("a log without the column has unlabelled records, and the writer keeps the column") {
    std::istringstream plain("truck_id,speed_mps,sprung_mass_kg,if_1\nT1,20,4000,1.0\n");
    io::WimLogReader p(plain, "plain.csv", 420.0);
    CHECK_FALSE(p.has_classes());
    REQUIRE(p.next(r, why) == io::WimLogReader::Status::record);
    CHECK(r.vehicle_class.empty());
    std::ostringstream out;
    io::write_wim_log(out, {r});
    CHECK(out.str().find("class") == std::string::npos);
    r.vehicle_class = "7";
    std::ostringstream labelled;
    io::write_wim_log(labelled, {r});
    CHECK(labelled.str().rfind("truck_id,class,", 0) == 0);
  }
}

TEST_CASE("the weighted quantile is type 7 for equal weights and a mixture's quantile otherwise", "[util][classes]") {
  std::vector<double> v{3.0, 1.0, 4.0, 1.5, 9.0, 2.6};
  std::vector<std::pair<double, double>> vw;
  for (double x : v) vw.emplace_back(x, 0.5);
  for (double p : {0.0, 0.025, 0.3, 0.5, 0.975, 1.0}) CHECK(weighted_quantile(vw, p) == Approx(quantile_type7(v, p)).epsilon(1e-14));
  // Two components, 1000 points each on a fine grid: 0.2 of the mass uniform on [0, 1], 0.8 on
  // [10, 11]. The mixture's 10 % quantile is at 0.5 of the first, its 60 % quantile at 0.5 of the second.
  std::vector<std::pair<double, double>> mix;
  for (int i = 0; i < 1000; ++i) {
    mix.emplace_back((i + 0.5) / 1000.0, 0.2 / 1000);
    mix.emplace_back(10.0 + (i + 0.5) / 1000.0, 0.8 / 1000);
  }
  CHECK(weighted_quantile(mix, 0.1) == Approx(0.5).margin(2e-3));
  CHECK(weighted_quantile(mix, 0.6) == Approx(10.5).margin(2e-3));
}

TEST_CASE("simulate --fleet-mix writes each truck's class in the shares asked for", "[cli][classes][simulate]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv"), truth = dir.file("truth.csv");
  const auto r = run_ssrfleet("simulate --trucks 400 --seed 3 --quiet --fleet-mix 'A:share=0.3,k-mean=350e3;B:share=0.7' "
                              "--out " + q(log) + " --truth " + q(truth), dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  const auto classes = class_column(log);
  REQUIRE(classes.size() == 400);
  const auto n_a = std::count(classes.begin(), classes.end(), "A");
  CHECK(n_a + std::count(classes.begin(), classes.end(), "B") == 400);
  // Binomial(400, 0.3): mean 120, sd 9.2; four sd.
  CHECK(std::abs(static_cast<double>(n_a) - 120.0) < 4.0 * std::sqrt(400 * 0.3 * 0.7));
  // The truth list says each truck's class, and class A's suspensions come from its own
  // distribution N(350e3, 50e3^2) (B keeps Table 1's 500e3): means within four sd / sqrt(n).
  CHECK(class_column(truth) == classes);
  std::ifstream in(truth);
  io::CsvReader csv(in, truth);
  io::CsvRow row;
  REQUIRE(csv.next(row));
  const auto k_col = static_cast<std::size_t>(io::column_index(row.fields, "k_npm"));
  std::map<std::string, std::pair<double, int>> k_sum;
  std::size_t i = 0;
  while (csv.next(row)) {
    auto& s = k_sum[classes[i++]];
    s.first += std::stod(row.fields[k_col]);
    ++s.second;
  }
  CHECK(std::abs(k_sum["A"].first / k_sum["A"].second - 350e3) < 4.0 * 50e3 / std::sqrt(k_sum["A"].second));
  CHECK(std::abs(k_sum["B"].first / k_sum["B"].second - 500e3) < 4.0 * 50e3 / std::sqrt(k_sum["B"].second));

  const auto bad = run_ssrfleet("simulate --trucks 10 --quiet --fleet-mix 'A:share=0.3;B:share=0.6' --out " + q(log), dir);
  CHECK(bad.status == 64);
  CHECK(bad.err.find("sum to 0.9") != std::string::npos);
}

TEST_CASE("fit gives each vehicle class its own posterior, near its own truth", "[cli][classes][fit][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv"), post = dir.file("post.json");
  REQUIRE(run_ssrfleet(std::string("simulate --trucks 80 --seed 21 --quiet --fleet-mix '") + kTwoClasses + "' --out " + q(log),
                       dir).status == 0);
  const auto fit = run_ssrfleet("fit " + q(log) + " --particles 256 --seed 2 --quiet --out " + q(post), dir);
  INFO(fit.err);
  REQUIRE(fit.status == 0);
  const auto classes = io::read_posterior_classes(post);
  REQUIRE(classes.size() == 2);
  CHECK(classes[0].label == "A");
  CHECK(classes[1].label == "B");
  CHECK(classes[0].cloud.trucks_seen + classes[1].cloud.trucks_seen == 80);
  const auto a = fleet::summarise_cloud(classes[0].cloud)[fleet::kK];
  const auto b = fleet::summarise_cloud(classes[1].cloud)[fleet::kK];
  INFO("K: A " << a.mean << " sd " << a.sd << ", B " << b.mean << " sd " << b.sd);
  // Each class's K within four of its posterior sd of its own truth; the two far apart.
  CHECK(std::abs(a.mean - 350e3) < 4.0 * a.sd);
  CHECK(std::abs(b.mean - 650e3) < 4.0 * b.sd);
  CHECK(std::abs(b.mean - a.mean) > 10.0 * std::hypot(a.sd, b.sd));
  // The file: format 2, the observed shares, each entry the usual posterior object.
  const auto j = nlohmann::json::parse(test::read_text(post));
  CHECK(j["format_version"] == 2);
  CHECK(j["trucks_seen"] == 80);
  CHECK(j["classes"][0]["share"].get<double>() == Approx(classes[0].cloud.trucks_seen / 80.0));
  CHECK(j["classes"][1].contains("K"));
  // A single-class reader refuses it by name.
  const auto e = test::data_error([&] { io::read_posterior_file(post); });
  REQUIRE(e.has_value());
  CHECK(e->field() == "classes");
}

TEST_CASE("a one-class log fits exactly as the same log without its class column", "[cli][classes][fit]") {
  test::TempDir dir;
  const std::string plain = dir.file("plain.csv"), labelled = dir.file("labelled.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 12 --seed 4 --quiet --out " + q(plain), dir).status == 0);
  // The same records with a class column "A".
  std::istringstream text(test::read_text(plain));
  std::ostringstream with_class;
  std::string line;
  bool header = true;
  while (std::getline(text, line)) {
    if (line.empty() || line[0] == '#') continue;
    with_class << line << (header ? ",class" : ",A") << "\n";
    header = false;
  }
  test::write_text(labelled, with_class.str());
  // The class's seed is derived from the seed and its label; fitted with that seed, the
  // unlabelled log gives the same posterior to the bit.
  const std::uint64_t seed = fleet::class_seed(7, "A");
  REQUIRE(run_ssrfleet("fit " + q(labelled) + " --particles 64 --final-sweeps 2 --seed 7 --quiet --out " +
                           q(dir.file("l.json")), dir).status == 0);
  REQUIRE(run_ssrfleet("fit " + q(plain) + " --particles 64 --final-sweeps 2 --seed " + std::to_string(seed) +
                           " --quiet --out " + q(dir.file("p.json")), dir).status == 0);
  auto l = nlohmann::json::parse(test::read_text(dir.file("l.json")));
  auto p = nlohmann::json::parse(test::read_text(dir.file("p.json")));
  // Each file's checksum seals that whole file (the classes file's sits at its top level, beside
  // "classes"), so it is not part of the class's entry.
  REQUIRE(p.contains("checksum"));
  REQUIRE(l.contains("checksum"));
  p.erase("checksum");
  REQUIRE(l["classes"].size() == 1);
  auto entry = l["classes"][0];
  CHECK(entry["label"] == "A");
  CHECK(entry["share"] == 1.0);
  entry.erase("label");
  entry.erase("trucks");
  entry.erase("share");
  CHECK(entry == p);
  CHECK(fleet::class_seed(7, "") == 7);  // an unlabelled log keeps the seed
}

TEST_CASE("predict combines classes by traffic share, or as the user mixes them", "[cli][classes][predict][heavy]") {
  const TwoClassFit& f = two_class_fit();
  const auto classes = io::read_posterior_classes(f.post);
  REQUIRE(classes.size() == 2);
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  predict::PredictionOptions o;
  o.theta_draws = 20;
  o.trucks_per_draw = 20;
  o.seed = 3;
  const auto alone = [&](std::size_t c) {
    predict::PredictionOptions oc = o;
    oc.seed = fleet::class_seed(o.seed, classes[c].label);
    return predict::predict_ssr(classes[c].cloud, site, {}, oc);
  };
  const auto pa = alone(0), pb = alone(1);
  SECTION("shares (1, 0) are class A's prediction") {
    const auto m = predict::predict_ssr_mixture(classes, {1.0, 0.0}, site, {}, o);
    CHECK((m.mean_if == pa.mean_if).all());
    CHECK((m.lower95 == pa.lower95).all());
    CHECK((m.upper95 == pa.upper95).all());
    CHECK((m.mean_upper95 == pa.mean_upper95).all());
  }
  SECTION("the default uses the observed shares: the mean is their weighted mean") {
    const auto w = fleet::observed_shares(classes);
    REQUIRE(w[0] == Approx(classes[0].cloud.trucks_seen / 24.0));
    const auto m = predict::predict_ssr_mixture(classes, w, site, {}, o);
    const Eigen::ArrayXd expected = w[0] * pa.mean_if + w[1] * pb.mean_if;
    CHECK(((m.mean_if - expected).abs() < 1e-12).all());
    // The limits are the mixture's, not an average of limits: the mixture's 2.5 % point lies
    // between the classes' (a property of any mixture's CDF), and the band of the mean within theirs.
    for (Eigen::Index i = 0; i < m.mean_if.size(); ++i) {
      CHECK(m.lower95[i] >= std::min(pa.lower95[i], pb.lower95[i]) - 1e-9);
      CHECK(m.lower95[i] <= std::max(pa.lower95[i], pb.lower95[i]) + 1e-9);
      CHECK(m.upper95[i] >= std::min(pa.upper95[i], pb.upper95[i]) - 1e-9);
      CHECK(m.upper95[i] <= std::max(pa.upper95[i], pb.upper95[i]) + 1e-9);
    }
  }
  SECTION("the command line: --class, --mix, and their errors") {
    const std::string args = "predict --posterior " + q(f.post) + " --draws 20 --trucks-per-draw 20 --seed 3 --quiet";
    const auto by_class = run_ssrfleet(args + " --class A", f.dir);
    const auto by_mix = run_ssrfleet(args + " --mix A=1,B=0", f.dir);
    REQUIRE(by_class.status == 0);
    REQUIRE(by_mix.status == 0);
    CHECK(by_class.out == by_mix.out);
    std::ostringstream csv;
    predict::write_prediction_csv(csv, pa);
    CHECK(by_class.out == csv.str());
    // The default is the observed mix, written out.
    std::ostringstream observed;
    observed.precision(17);
    const auto w = fleet::observed_shares(classes);
    observed << " --mix A=" << w[0] << ",B=" << w[1];
    const auto by_default = run_ssrfleet(args, f.dir);
    REQUIRE(by_default.status == 0);
    CHECK(by_default.out == run_ssrfleet(args + observed.str(), f.dir).out);
    CHECK(by_default.out != by_class.out);
    const auto short_mix = run_ssrfleet(args + " --mix A=0.5,B=0.4", f.dir);
    CHECK(short_mix.status == 64);
    CHECK(short_mix.err.find("sum to 0.9") != std::string::npos);
    const auto unknown = run_ssrfleet(args + " --mix A=0.5,C=0.5", f.dir);
    CHECK(unknown.status == 64);
    CHECK(unknown.err.find("'C'") != std::string::npos);
    CHECK(unknown.err.find("A, B") != std::string::npos);
    CHECK(run_ssrfleet(args + " --class C", f.dir).status == 64);
  }
}

TEST_CASE("damage combines classes: the mixture's moments, by share", "[cli][classes][damage]") {
  SECTION("known answer: two classes of one truck pattern each") {
    // Class 1 at IF 1.2, class 2 at IF 0.9 everywhere, shares 0.25 / 0.75, 3 θ draws of 2 + 2 trucks.
    const std::vector<double> pos{10.0, 20.0};
    const int R = 3, T = 4;
    Eigen::ArrayXXd wheel_if(2, R * T);
    Eigen::ArrayXd load = Eigen::ArrayXd::Constant(R * T, 40e3), weight(T);
    weight << 0.125, 0.125, 0.375, 0.375;
    for (int r = 0; r < R; ++r) {
      wheel_if.col(r * T) = wheel_if.col(r * T + 1) = 1.2;
      wheel_if.col(r * T + 2) = wheel_if.col(r * T + 3) = 0.9;
    }
    damage::DamageOptions o;
    const auto p = damage::summarise_damage(pos, wheel_if, load, R, T, o, weight);
    const double a1 = 0.25 * 1.2 + 0.75 * 0.9, a2 = 0.25 * 1.44 + 0.75 * 0.81;
    CHECK(p.powers[0].mean[0] == Approx(a1).epsilon(1e-12));
    CHECK(p.powers[1].mean[1] == Approx(0.25 * std::pow(1.2, 4) + 0.75 * std::pow(0.9, 4)).epsilon(1e-12));
    CHECK(p.dlc[0] == Approx(std::sqrt(a2 - a1 * a1)).epsilon(1e-9));
    const auto esal = [](double wheel_n) { return std::pow(2.0 * wheel_n / 80e3, 4); };
    CHECK(p.esal_per_million[0] == Approx(1e6 * (0.25 * esal(1.2 * 40e3) + 0.75 * esal(0.9 * 40e3))).epsilon(1e-12));
    CHECK(p.static_esal_per_million == Approx(1e6 * esal(40e3)).epsilon(1e-12));
  }
  SECTION("from a two-class posterior: (1, 0) is class A alone, the default a1 the shares' weighted mean") {
    const TwoClassFit& f = two_class_fit();
    const auto classes = io::read_posterior_classes(f.post);
    const site::Site site(site::load_road("AS1"), site::SiteOptions{});
    damage::DamageOptions o;
    o.theta_draws = 10;
    o.trucks_per_draw = 10;
    const auto alone = [&](std::size_t c) {
      damage::DamageOptions oc = o;
      oc.seed = fleet::class_seed(o.seed, classes[c].label);
      return damage::predict_damage(classes[c].cloud, site, {}, oc);
    };
    const auto da = alone(0), db = alone(1);
    const auto only_a = damage::predict_damage_mixture(classes, {1.0, 0.0}, site, {}, o);
    CHECK(only_a.powers[1].mean == da.powers[1].mean);
    CHECK(only_a.esal_per_million == da.esal_per_million);
    const auto w = fleet::observed_shares(classes);
    const auto m = damage::predict_damage_mixture(classes, w, site, {}, o);
    CHECK(m.simulated_passes == 2 * 10 * 10);
    for (std::size_t i = 0; i < m.position_m.size(); ++i) {
      CHECK(m.powers[0].mean[i] == Approx(w[0] * da.powers[0].mean[i] + w[1] * db.powers[0].mean[i]).epsilon(1e-12));
      CHECK(m.powers[1].mean[i] == Approx(w[0] * da.powers[1].mean[i] + w[1] * db.powers[1].mean[i]).epsilon(1e-12));
    }
    const auto bad = run_ssrfleet("damage --posterior " + q(f.post) + " --draws 4 --trucks-per-draw 4 --mix A=0.6,B=0.3 --quiet", f.dir);
    CHECK(bad.status == 64);
    CHECK(bad.err.find("sum to 0.9") != std::string::npos);
  }
}

TEST_CASE("a class-labelled stream resumes exactly, and quarantines a class outside a fixed list", "[cli][classes][stream][heavy]") {
  test::TempDir dir;
  const std::string log = dir.file("log.csv");
  REQUIRE(run_ssrfleet(std::string("simulate --trucks 16 --seed 9 --quiet --fleet-mix '") + kTwoClasses + "' --out " + q(log),
                       dir).status == 0);
  const std::string args = " --particles 64 --threads 2 --seed 4 --quiet";
  // Uninterrupted.
  const std::string whole = dir.file("whole");
  const auto r = run_ssrfleet("stream --state " + q(whole) + " --input " + q(log) + args, dir);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("(classes A, B at their observed shares)") != std::string::npos);
  // The first 9 trucks, then a resume on the whole log (the 9 are skipped by truck_id).
  const std::string text = test::read_text(log);
  std::size_t cut = 0;
  for (int lines = 0; lines < 11; ++lines) cut = text.find('\n', cut) + 1;  // comment + header + 9 records
  test::write_text(dir.file("part.csv"), text.substr(0, cut));
  const std::string resumed = dir.file("resumed");
  REQUIRE(run_ssrfleet("stream --state " + q(resumed) + " --input " + q(dir.file("part.csv")) + args, dir).status == 0);
  const auto again = run_ssrfleet("stream --state " + q(resumed) + " --input " + q(log) + args, dir);
  INFO(again.err);
  REQUIRE(again.status == 0);
  CHECK(again.err.find("9 skipped") != std::string::npos);
  CHECK(test::read_text(resumed + "/posterior.json") == test::read_text(whole + "/posterior.json"));
  CHECK(std::filesystem::exists(whole + "/trucks.A.bin"));
  CHECK(std::filesystem::exists(whole + "/trucks.B.bin"));
  // The stream's posterior is fit's without final sweeps, class by class.
  REQUIRE(run_ssrfleet("fit " + q(log) + " --particles 64 --seed 4 --final-sweeps 0 --quiet --out " + q(dir.file("fit.json")),
                       dir).status == 0);
  CHECK(test::read_text(dir.file("fit.json")) == test::read_text(whole + "/posterior.json"));
  // The history: every checkpoint reports each class seen so far, and the last report's
  // summaries are each class's in posterior.json.
  {
    const io::HistoryDb history(whole + "/history.sqlite", "base");
    REQUIRE(history.last_seq() == 16u);
    const auto last = history.read_report(16);
    CHECK(last.trucks == 16);
    REQUIRE(last.hyperparameters.size() == 2 * 7u);
    const auto classes_now = io::read_posterior_classes(whole);
    for (std::size_t c = 0; c < 2; ++c) {
      const auto summary = fleet::summarise_cloud(classes_now[c].cloud);
      CHECK(last.hyperparameters[7 * c].vehicle_class == classes_now[c].label);
      CHECK(last.hyperparameters[7 * c].mean == Approx(summary[0].mean).epsilon(1e-12));
    }
  }

  // Classes fixed to A: every B record is quarantined, nothing lost.
  const auto classes = class_column(log);
  const auto n_a = std::count(classes.begin(), classes.end(), "A");
  REQUIRE(n_a > 0);
  REQUIRE(n_a < 16);
  const std::string fixed = dir.file("fixed");
  const auto only_a = run_ssrfleet("stream --state " + q(fixed) + " --classes A --input " + q(log) + args, dir);
  INFO(only_a.err);
  REQUIRE(only_a.status == 0);
  CHECK(only_a.err.find(std::to_string(n_a) + " trucks absorbed, " + std::to_string(16 - n_a) + " rejected") !=
        std::string::npos);
  const std::string rejects = test::read_text(fixed + "/rejects.csv");
  CHECK(static_cast<long>(std::count(rejects.begin(), rejects.end(), '\n')) == 2 + 2 * (16 - n_a));
  CHECK(rejects.find(": class: class 'B' is not one of the classes fixed") != std::string::npos);
  const auto posterior = io::read_posterior_classes(fixed);
  REQUIRE(posterior.size() == 1);
  CHECK(posterior[0].label == "A");
  CHECK(posterior[0].cloud.trucks_seen == n_a);
  // A resume keeps the list: another is refused.
  const auto other = run_ssrfleet("stream --state " + q(fixed) + " --classes A,B --input " + q(log) + args, dir);
  CHECK(other.status == 64);

  // A state of format 3 (before classes) is refused by name.
  const std::string old_state = dir.file("old");
  std::filesystem::create_directories(old_state);
  test::write_text(old_state + "/checkpoint.bin", std::string("SSRFSTRM\x03\0\0\0", 12) + std::string(64, '\0'));
  const auto old = run_ssrfleet("stream --state " + q(old_state) + " --input " + q(log) + args, dir);
  CHECK(old.status == 65);
  CHECK(old.err.find("version 3 (before vehicle classes and the history)") != std::string::npos);
}

TEST_CASE("weigh takes a class of a classes posterior", "[cli][classes][weigh]") {
  const TwoClassFit& f = two_class_fit();
  const std::string forces = f.dir.file("forces.csv");
  REQUIRE(run_ssrfleet("simulate --trucks 2 --seed 2 --forces --quiet --out " + q(forces), f.dir).status == 0);
  const std::string args = "weigh " + q(forces) + " --posterior " + q(f.post) + " --draws 4 --trucks-per-draw 8 --quiet";
  const auto none = run_ssrfleet(args, f.dir);
  CHECK(none.status == 64);
  CHECK(none.err.find("A, B") != std::string::npos);
  const auto a = run_ssrfleet(args + " --class A", f.dir);
  INFO(a.err);
  CHECK(a.status == 0);
}
