#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <boost/math/distributions/normal.hpp>
#include <boost/random/cauchy_distribution.hpp>
#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "test_support.hpp"
#include "util/convergence.hpp"

using namespace ssrfleet;

namespace {

// m chains of n draws of x_t = rho x_{t-1} + sqrt(1 - rho^2) e_t, each started in its stationary
// law N(0, 1), chain c shifted by shift[c] (0 when shift is shorter).
Eigen::MatrixXd ar1_chains(double rho, Eigen::Index n, Eigen::Index m, std::uint64_t seed,
                           const std::vector<double>& shift = {}) {
  boost::random::mt19937_64 engine(seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  const double innovation = std::sqrt(1.0 - rho * rho);
  Eigen::MatrixXd x(n, m);
  for (Eigen::Index c = 0; c < m; ++c) {
    double state = normal(engine);
    for (Eigen::Index t = 0; t < n; ++t) {
      if (t > 0) state = rho * state + innovation * normal(engine);
      x(t, c) =
          state + (static_cast<std::size_t>(c) < shift.size() ? shift[static_cast<std::size_t>(c)] : 0.0);
    }
  }
  return x;
}

// Heavy tails whose scale mixes slowly: x_t = exp(h_t) e_t, e_t iid standard Cauchy, h_t a
// stationary AR(1) with correlation 0.98 and sd 1. The sign and centre of x change every draw (a
// large bulk-ESS) while how far out it reaches follows h (a small tail-ESS); the mean does not exist.
Eigen::MatrixXd volatile_cauchy_chains(Eigen::Index n, Eigen::Index m, std::uint64_t seed) {
  boost::random::mt19937_64 engine(seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  boost::random::cauchy_distribution<double> cauchy(0.0, 1.0);
  const double phi = 0.98, innovation = std::sqrt(1.0 - phi * phi);
  Eigen::MatrixXd x(n, m);
  for (Eigen::Index c = 0; c < m; ++c) {
    double h = normal(engine);
    for (Eigen::Index t = 0; t < n; ++t) {
      if (t > 0) h = phi * h + innovation * normal(engine);
      x(t, c) = std::exp(h) * cauchy(engine);
    }
  }
  return x;
}

nlohmann::json summary_json(const util::ConvergenceSummary& s) {
  return {{"mean", s.mean},
          {"sd", s.sd},
          {"q05", s.q05},
          {"q50", s.q50},
          {"q95", s.q95},
          {"rhat", s.rhat},
          {"rhat_bulk", s.rhat_bulk},
          {"rhat_tail", s.rhat_tail},
          {"rhat_unsplit", s.rhat_unsplit},
          {"ess_bulk", s.ess_bulk},
          {"ess_tail", s.ess_tail},
          {"ess_q05", s.ess_q05},
          {"ess_q95", s.ess_q95},
          {"ess_mean", s.ess_mean},
          {"mcse_mean", s.mcse_mean},
          {"mcse_q05", s.mcse_q05},
          {"mcse_q95", s.mcse_q95}};
}

}  // namespace

// The fixed draws that tests/convergence_reference.py recomputes with numpy from the paper's
// equations: the script runs this case with SSRFLEET_CONVERGENCE_CASES naming the JSON file to
// write, holding each case's draws (chain by chain) and this library's summary of them. Run
// without it, the file goes to a scratch directory. Either way the draws must read back to the bit,
// or the script would check other numbers than these.
TEST_CASE("the convergence reference cases are written for the numpy check and read back exactly",
          "[util][convergence][convergence-reference]") {
  test::TempDir scratch;
  const char* given = std::getenv("SSRFLEET_CONVERGENCE_CASES");
  const std::string path = given != nullptr ? std::string(given) : scratch.file("cases.json");
  struct Case {
    std::string name;
    Eigen::MatrixXd draws;
  };
  Eigen::MatrixXd ties = ar1_chains(0.6, 501, 3, 404);
  ties = (ties.array() * 2.0).round() / 2.0;  // steps of 0.5: many ties
  const std::vector<Case> cases = {
      {"four well-mixed AR(1) chains", ar1_chains(0.5, 1000, 4, 101)},
      {"one of four chains shifted by 3 sd", ar1_chains(0.5, 1000, 4, 202, {0.0, 0.0, 0.0, 3.0})},
      {"heavy tails, bulk and tail differ", volatile_cauchy_chains(1000, 4, 303)},
      {"three chains of an odd length with ties", ties},
      {"one chain of an odd length", ar1_chains(0.8, 1001, 1, 505)},
  };
  nlohmann::json out = {{"cases", nlohmann::json::array()}};
  for (const Case& c : cases) {
    nlohmann::json chains = nlohmann::json::array();
    for (Eigen::Index j = 0; j < c.draws.cols(); ++j)
      chains.push_back(std::vector<double>(c.draws.col(j).data(), c.draws.col(j).data() + c.draws.rows()));
    out["cases"].push_back({{"name", c.name},
                            {"chains", chains},
                            {"summary", summary_json(util::summarise_convergence(c.draws))}});
  }
  {
    std::ofstream file(path);
    file << out.dump() << "\n";
    REQUIRE(file.good());
  }
  std::ifstream file(path);
  const nlohmann::json back = nlohmann::json::parse(file);
  REQUIRE(back["cases"].size() == cases.size());
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Eigen::MatrixXd& draws = cases[i].draws;
    const nlohmann::json& chains = back["cases"][i]["chains"];
    REQUIRE(chains.size() == static_cast<std::size_t>(draws.cols()));
    bool exact = true;
    for (Eigen::Index j = 0; j < draws.cols(); ++j) {
      const auto read = chains[static_cast<std::size_t>(j)].get<std::vector<double>>();
      exact = exact && read.size() == static_cast<std::size_t>(draws.rows()) &&
              std::equal(read.begin(), read.end(), draws.col(j).data());
    }
    INFO(cases[i].name);
    CHECK(exact);
  }
}

TEST_CASE("R-hat is 1 and ESS is the number of draws for independent normal draws", "[util][convergence]") {
  // 4 chains of 250,000 iid N(0, 1), split into 8 of n = 125,000. Bulk and tail R-hat are those of
  // (near) normal split chains, whose R-hat^2 = (n-1)/n + var(means)/W with n var(means)/W ~
  // chi^2_7/7 =: F. So R-hat >= sqrt(1 - 1/n), and R-hat - 1 ~ (F - 1)/(2n) < 5/(2n) unless F > 6,
  // which has probability below 1e-6 (chi^2_7 > 42).
  const Eigen::MatrixXd x = ar1_chains(0.0, 250000, 4, 7);
  const util::ConvergenceSummary s = util::summarise_convergence(x);
  const double n = 125000.0, draws = 1e6;
  INFO("rhat bulk " << s.rhat_bulk << ", tail " << s.rhat_tail);
  CHECK(s.rhat == std::max(s.rhat_bulk, s.rhat_tail));
  CHECK(s.rhat < 1.0 + 2.5 / n);
  CHECK(s.rhat_bulk > std::sqrt(1.0 - 1.0 / n));
  CHECK(s.rhat_tail > std::sqrt(1.0 - 1.0 / n));
  // Not split: 4 chains of N = 250,000, N var(means)/W ~ chi^2_3/3 =: G, so R-hat - 1 ~ (G - 1)/(2N)
  // < 10/(2N) unless G > 11 (chi^2_3 > 33, probability below 1e-6).
  const double N = 250000.0;
  INFO("rhat unsplit " << s.rhat_unsplit);
  CHECK(s.rhat_unsplit < 1.0 + 5.0 / N);
  CHECK(s.rhat_unsplit > std::sqrt(1.0 - 1.0 / N));
  // ESS = S / tau with tau - 1 a sum of a few autocorrelation estimates, each N(0, 1/S) for iid
  // draws: weight 2 on up to 16 lags gives an sd of at most 2 sqrt(16/S) = 0.008 at S = 10^6, so
  // 4 % is 5 sd. The quantile indicators are iid too.
  INFO("ESS bulk " << s.ess_bulk << ", mean " << s.ess_mean << ", q05 " << s.ess_q05 << ", q95 "
                   << s.ess_q95);
  CHECK(s.ess_bulk == Approx(draws).epsilon(0.04));
  CHECK(s.ess_mean == Approx(draws).epsilon(0.04));
  CHECK(s.ess_q05 == Approx(draws).epsilon(0.04));
  CHECK(s.ess_q95 == Approx(draws).epsilon(0.04));
  CHECK(s.ess_tail == std::min(s.ess_q05, s.ess_q95));
  // MCSE of the mean sd / sqrt(ESS): 1/sqrt(S) within half the ESS's 4 % and the sd's 0.1 %.
  CHECK(s.mcse_mean == Approx(1.0 / std::sqrt(draws)).epsilon(0.025));
  // MCSE of the p-quantile: asymptotically sqrt(p (1-p) / S) / phi(z_p). The estimate is half the
  // distance between order statistics d = 2 sqrt(p (1-p) S) = 436 apart, whose relative sd is
  // about 1/sqrt(d) = 0.048 (a sum of d near-exponential spacings): 20 % is 4 sd.
  const boost::math::normal standard;
  for (const auto& [p, mcse] : {std::pair{0.05, s.mcse_q05}, std::pair{0.95, s.mcse_q95}}) {
    const double expected =
        std::sqrt(p * (1.0 - p) / draws) / boost::math::pdf(standard, boost::math::quantile(standard, p));
    INFO("p " << p << ": MCSE " << mcse << ", asymptotic " << expected);
    CHECK(mcse == Approx(expected).epsilon(0.2));
  }
}

TEST_CASE("ESS of AR(1) chains is S (1 - rho) / (1 + rho) within Monte Carlo error", "[util][convergence]") {
  // The integrated autocorrelation time of AR(1) is (1 + rho) / (1 - rho). The estimator's
  // relative sd is about sqrt(2 (2L + 1) / S) for a window of L lags, a few tau: at rho = 0.9
  // (tau = 19, L about 60) and S = 10^6 that is 0.016, so 10 % is 6 sd. Rank-normalising
  // stationary N(0, 1) draws leaves them nearly as they are, so bulk-ESS follows the same law.
  for (const double rho : {0.5, 0.9}) {
    const Eigen::MatrixXd x = ar1_chains(rho, 250000, 4, 31 + static_cast<std::uint64_t>(10 * rho));
    const double expected = 1e6 * (1.0 - rho) / (1.0 + rho);
    const util::ConvergenceSummary s = util::summarise_convergence(x);
    INFO("rho " << rho << ": ESS mean " << s.ess_mean << ", bulk " << s.ess_bulk << ", expected "
                << expected);
    CHECK(s.ess_mean == Approx(expected).epsilon(0.10));
    CHECK(s.ess_bulk == Approx(expected).epsilon(0.10));
    CHECK(s.rhat < 1.01);
  }
}

TEST_CASE("a chain shifted by 3 sd gives R-hat far above 1", "[util][convergence]") {
  // Rank-normalised, the shifted chain's halves sit near z = 1.3 and the others' near -0.4, so
  // var(means) over the 8 halves is about 0.6 against W about 0.5: R-hat about sqrt(1 + 1.2) = 1.5,
  // with Monte Carlo error of order 1/sqrt(n) = 0.03 in var(means). The paper's threshold is 1.01.
  const Eigen::MatrixXd x = ar1_chains(0.5, 1000, 4, 202, {0.0, 0.0, 0.0, 3.0});
  const util::ConvergenceSummary s = util::summarise_convergence(x);
  INFO("rhat bulk " << s.rhat_bulk << ", tail " << s.rhat_tail);
  CHECK(s.rhat_bulk > 1.3);
  CHECK(s.rhat > 1.3);
  // Not split (the 4 chains as 4 independent runs): var(means) over 4 is about 0.7 against W 0.5.
  CHECK(s.rhat_unsplit > 1.3);
  // The same chains unshifted pass.
  CHECK(util::rhat(ar1_chains(0.5, 1000, 4, 202)) < 1.01);
}

TEST_CASE("tail R-hat sees chains that differ only in scale, bulk R-hat does not", "[util][convergence]") {
  // Four chains of iid N(0, s_c^2), s = 1, 1, 1, 3: the same location, so the bulk (ranks) mixes,
  // while |x - median| of the wide chain ranks high: the folded R-hat is about 1.15 with Monte Carlo
  // sd near 0.01 (var(means) of the folded ranks is known to about 1/sqrt(n)), so 1.05 is 10 sd off.
  Eigen::MatrixXd x = ar1_chains(0.0, 2000, 4, 77);
  x.col(3) *= 3.0;
  const util::ConvergenceSummary s = util::summarise_convergence(x);
  INFO("rhat bulk " << s.rhat_bulk << ", tail " << s.rhat_tail);
  CHECK(s.rhat_bulk < 1.01);
  CHECK(s.rhat_tail > 1.05);
  CHECK(s.rhat == s.rhat_tail);
}

TEST_CASE("heavy tails with a slowly mixing scale: tail-ESS far below bulk-ESS", "[util][convergence]") {
  const Eigen::MatrixXd x = volatile_cauchy_chains(1000, 4, 303);
  const util::ConvergenceSummary s = util::summarise_convergence(x);
  INFO("ESS bulk " << s.ess_bulk << ", tail " << s.ess_tail);
  CHECK(s.ess_tail < 0.5 * s.ess_bulk);
}

TEST_CASE("rank-based diagnostics do not change under an increasing transformation", "[util][convergence]") {
  const Eigen::MatrixXd x = ar1_chains(0.7, 999, 3, 12);
  const Eigen::MatrixXd y = x.array().exp().matrix();
  CHECK(util::rhat_bulk(y) == util::rhat_bulk(x));
  CHECK(util::ess_bulk(y) == util::ess_bulk(x));
  CHECK(util::ess_tail(y) == util::ess_tail(x));
  // Moment-based ones do.
  CHECK(util::ess_mean(y) != util::ess_mean(x));
}

TEST_CASE("one chain is split in two, and odd lengths drop the middle draw", "[util][convergence]") {
  Eigen::MatrixXd x(5, 2);
  x << 1, 10, 2, 20, 3, 30, 4, 40, 5, 50;
  const Eigen::MatrixXd split = util::split_chains(x);
  REQUIRE(split.rows() == 2);
  REQUIRE(split.cols() == 4);
  CHECK((split.col(0) == Eigen::Vector2d(1, 2)));
  CHECK((split.col(1) == Eigen::Vector2d(4, 5)));
  CHECK((split.col(3) == Eigen::Vector2d(40, 50)));
  const util::ConvergenceSummary s = util::summarise_convergence(ar1_chains(0.3, 2001, 1, 9));
  CHECK(s.chains == 1);
  CHECK(std::isfinite(s.rhat));
  CHECK(std::isfinite(s.ess_bulk));
  CHECK(std::isfinite(s.mcse_q95));
}

TEST_CASE("rank normalisation gives tied draws their average rank", "[util][convergence]") {
  Eigen::MatrixXd x(4, 1);
  x << 3.0, 1.0, 3.0, 2.0;  // ranks 3.5, 1, 3.5, 2 of S = 4
  const Eigen::MatrixXd z = util::rank_normalise(x);
  const boost::math::normal standard;
  const auto score = [&](double r) { return boost::math::quantile(standard, (r - 0.375) / 4.25); };
  CHECK(z(0, 0) == Approx(score(3.5)).epsilon(1e-14));
  CHECK(z(2, 0) == z(0, 0));
  CHECK(z(1, 0) == Approx(score(1.0)).epsilon(1e-14));
  CHECK(z(3, 0) == Approx(score(2.0)).epsilon(1e-14));
}

TEST_CASE("undefined diagnostics are NaN, and malformed sets are refused", "[util][convergence]") {
  const Eigen::MatrixXd constant = Eigen::MatrixXd::Constant(100, 4, 2.5);
  const util::ConvergenceSummary s = util::summarise_convergence(constant);
  CHECK(std::isnan(s.rhat));
  CHECK(std::isnan(s.ess_bulk));
  CHECK(std::isnan(s.ess_tail));
  CHECK(std::isnan(s.mcse_q05));
  Eigen::MatrixXd with_inf = ar1_chains(0.5, 100, 4, 3);
  with_inf(10, 2) = std::numeric_limits<double>::infinity();
  CHECK(std::isnan(util::rhat(with_inf)));
  CHECK(std::isnan(util::ess_mean(with_inf)));
  CHECK(std::isnan(util::ess_bulk(Eigen::MatrixXd::Constant(3, 1, 1.0))));
  CHECK_THROWS_AS(util::summarise_convergence(Eigen::MatrixXd(0, 4)), std::invalid_argument);
  CHECK_THROWS_AS(util::summarise_parameters({}), std::invalid_argument);
  CHECK_THROWS_AS(util::summarise_parameters({Eigen::MatrixXd::Zero(10, 2), Eigen::MatrixXd::Zero(10, 3)}),
                  std::invalid_argument);
  CHECK_THROWS_AS(util::ess_quantile(with_inf, 1.0), std::invalid_argument);
}

TEST_CASE("a set of parameters is summarised column by column", "[util][convergence]") {
  // Two chains of three parameters; parameter j's draws x chains are the chains' column j.
  std::vector<Eigen::MatrixXd> chains(2, Eigen::MatrixXd(400, 3));
  const Eigen::MatrixXd p0 = ar1_chains(0.2, 400, 2, 1), p1 = ar1_chains(0.6, 400, 2, 2),
                        p2 = ar1_chains(0.9, 400, 2, 3);
  for (int c = 0; c < 2; ++c) {
    chains[static_cast<std::size_t>(c)].col(0) = p0.col(c);
    chains[static_cast<std::size_t>(c)].col(1) = p1.col(c);
    chains[static_cast<std::size_t>(c)].col(2) = p2.col(c);
  }
  const std::vector<util::ConvergenceSummary> all = util::summarise_parameters(chains);
  REQUIRE(all.size() == 3);
  int j = 0;
  for (const Eigen::MatrixXd* p : {&p0, &p1, &p2}) {
    const util::ConvergenceSummary one = util::summarise_convergence(*p);
    const util::ConvergenceSummary& got = all[static_cast<std::size_t>(j++)];
    CHECK(got.rhat == one.rhat);
    CHECK(got.ess_bulk == one.ess_bulk);
    CHECK(got.ess_tail == one.ess_tail);
    CHECK(got.mcse_mean == one.mcse_mean);
    CHECK(got.mcse_q95 == one.mcse_q95);
  }
  // In parallel chunks of one parameter, last first: the same bits.
  const util::ParallelRange backwards = [](Eigen::Index n, const util::RangeBody& body) {
    for (Eigen::Index j = n - 1; j >= 0; --j) body(j, j + 1);
  };
  const std::vector<util::ConvergenceSummary> chunked = util::summarise_parameters(chains, backwards);
  for (std::size_t i = 0; i < 3; ++i) {
    CHECK(chunked[i].rhat == all[i].rhat);
    CHECK(chunked[i].ess_tail == all[i].ess_tail);
    CHECK(chunked[i].mcse_q05 == all[i].mcse_q05);
  }
  // Slower mixing, fewer effective draws.
  CHECK(all[0].ess_bulk > all[1].ess_bulk);
  CHECK(all[1].ess_bulk > all[2].ess_bulk);
}
