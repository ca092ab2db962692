// The tempered SMC engine on a model with a closed-form evidence: a Gaussian chain
//   θ ~ N(0, 1),  x_j | θ ~ N(θ, τ²),  y_j | x_j ~ N(x_j, s²),  j = 1..N,
// so y ~ N(0, 11ᵀ + (τ² + s²) I). It exercises both uses of the engine: static tempering of all
// N records at once, and one data-tempered stage per record (IBIS), where each stage first
// extends every particle with the new record's latent x_n ~ N(θ, τ²). Two MH blocks (θ and the
// latents) check that the engine's cache of log γ and ℓ stays right across blocks.
#include <catch2/catch.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <boost/random/normal_distribution.hpp>

#include "smc/engine.hpp"
#include "util/errors.hpp"

namespace smc = ssrfleet::smc;
using Catch::Matchers::Contains;

namespace {

constexpr double kTau = 0.5, kNoise = 0.3;
const std::vector<double> kRecords = {0.8, 1.4, 0.3, 1.9, 0.9, 1.2};

double log_normal(double v, double mean, double sd) {
  constexpr double half_log_2pi = 0.91893853320467274178;
  const double z = (v - mean) / sd;
  return -half_log_2pi - std::log(sd) - 0.5 * z * z;
}

double exact_log_evidence(const std::vector<double>& y) {
  const auto n = static_cast<Eigen::Index>(y.size());
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Ones(n, n) + (kTau * kTau + kNoise * kNoise) * Eigen::MatrixXd::Identity(n, n);
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  const Eigen::VectorXd yv = Eigen::Map<const Eigen::VectorXd>(y.data(), n);
  const Eigen::VectorXd z = llt.matrixL().solve(yv);
  const double log_det = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return -0.5 * static_cast<double>(n) * std::log(2.0 * M_PI) - 0.5 * log_det - 0.5 * z.squaredNorm();
}

class GaussianChainModel : public smc::TemperedModel {
 public:
  GaussianChainModel(std::vector<double> y, Eigen::Index P, const smc::RngFactory& rngs)
      : y_(std::move(y)), theta_(1, P), x_(static_cast<Eigen::Index>(y_.size()), P) {
    boost::random::normal_distribution<double> normal;
    for (Eigen::Index i = 0; i < P; ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      theta_(0, i) = normal(rng);
    }
  }

  // IBIS: the next record's latent joins from its conditional prior; only its likelihood is tempered.
  void add_record(const smc::RngFactory& rngs) {
    boost::random::normal_distribution<double> normal;
    for (Eigen::Index i = 0; i < theta_.cols(); ++i) {
      smc::Rng rng = rngs.stream(static_cast<std::uint64_t>(i));
      x_(n_, i) = theta_(0, i) + kTau * normal(rng);
    }
    first_tempered_ = n_;
    ++n_;
  }
  // Static tempering: every latent from the prior, every likelihood tempered at once.
  void add_all_records(const smc::RngFactory& rngs) {
    while (n_ < static_cast<Eigen::Index>(y_.size())) add_record(rngs.child(static_cast<std::uint64_t>(n_)));
    first_tempered_ = 0;
  }

  Eigen::Index nan_particle = -1;  // if >= 0, this particle's ℓ is NaN

  Eigen::Index particles() const override { return theta_.cols(); }

  void log_density(Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> ll,
                   const smc::ParallelFor& parallel) override {
    parallel(theta_.cols(), [&](Eigen::Index b, Eigen::Index e) {
      for (Eigen::Index i = b; i < e; ++i) evaluate(i, theta_(0, i), x_.col(i), log_base[i], ll[i]);
    });
  }

  std::vector<smc::BlockSpec> blocks() const override { return {{"theta", 1}, {"x", n_}}; }

  void get_block(int block, Eigen::Ref<Eigen::MatrixXd> values) const override {
    if (block == 0)
      values = theta_;
    else
      values = x_.topRows(n_);
  }

  void log_density_at(int block, const Eigen::Ref<const Eigen::MatrixXd>& proposed, Eigen::Ref<Eigen::ArrayXd> log_base,
                      Eigen::Ref<Eigen::ArrayXd> ll, const smc::ParallelFor& parallel) override {
    ++batched_calls;
    parallel(theta_.cols(), [&](Eigen::Index b, Eigen::Index e) {
      for (Eigen::Index i = b; i < e; ++i) {
        if (block == 0)
          evaluate(i, proposed(0, i), x_.col(i), log_base[i], ll[i]);
        else  // the latents block is x_1..x_n, all that evaluate() reads
          evaluate(i, theta_(0, i), proposed.col(i), log_base[i], ll[i]);
      }
    });
  }

  void accept(int block, const std::vector<char>& accepted, const Eigen::Ref<const Eigen::MatrixXd>& proposed) override {
    for (Eigen::Index i = 0; i < theta_.cols(); ++i) {
      if (!accepted[static_cast<std::size_t>(i)]) continue;
      if (block == 0)
        theta_(0, i) = proposed(0, i);
      else
        x_.col(i).head(n_) = proposed.col(i);
    }
  }

  void resample(const std::vector<Eigen::Index>& a) override {
    Eigen::MatrixXd t(theta_.rows(), theta_.cols()), x(x_.rows(), x_.cols());
    for (Eigen::Index i = 0; i < theta_.cols(); ++i) {
      t.col(i) = theta_.col(a[static_cast<std::size_t>(i)]);
      x.col(i) = x_.col(a[static_cast<std::size_t>(i)]);
    }
    theta_.swap(t);
    x_.swap(x);
  }

  const Eigen::MatrixXd& theta() const { return theta_; }
  const Eigen::MatrixXd& x() const { return x_; }
  int batched_calls = 0;

 private:
  // Reads x[0 .. n-1] only.
  void evaluate(Eigen::Index i, double theta, const Eigen::Ref<const Eigen::VectorXd>& x, double& log_base,
                double& ll) const {
    log_base = log_normal(theta, 0.0, 1.0);
    ll = 0.0;
    for (Eigen::Index j = 0; j < n_; ++j) {
      log_base += log_normal(x[j], theta, kTau);
      const double lj = log_normal(y_[static_cast<std::size_t>(j)], x[j], kNoise);
      (j < first_tempered_ ? log_base : ll) += lj;
    }
    if (i == nan_particle) ll = std::numeric_limits<double>::quiet_NaN();
  }

  std::vector<double> y_;
  Eigen::MatrixXd theta_, x_;
  Eigen::Index n_ = 0, first_tempered_ = 0;
};

smc::TemperedSampler::Options chain_options(Eigen::Index P, std::uint64_t seed, int threads = 2) {
  smc::TemperedSampler::Options o;
  o.particles = P;
  o.seed = seed;
  o.threads = threads;
  return o;
}

struct ChainRun {
  double log_z = 0.0;
  std::vector<smc::StageSummary> stages;
  Eigen::MatrixXd theta, x;
  Eigen::ArrayXd log_weights;
};

ChainRun run_ibis(const smc::TemperedSampler::Options& options) {
  smc::TemperedSampler sampler(options);
  // Prior draws of θ and each new latent from distinct streams (child 0, child 1).
  GaussianChainModel model(kRecords, options.particles, sampler.model_rngs().child(0));
  for (std::size_t n = 0; n < kRecords.size(); ++n) {
    model.add_record(sampler.model_rngs().child(1));
    sampler.run_stage(model, "record " + std::to_string(n));
  }
  return {sampler.log_evidence(), sampler.history(), model.theta(), model.x(), sampler.log_weights()};
}

ChainRun run_static(const smc::TemperedSampler::Options& options) {
  smc::TemperedSampler sampler(options);
  GaussianChainModel model(kRecords, options.particles, sampler.model_rngs().child(0));
  model.add_all_records(sampler.model_rngs().child(1));
  sampler.run_stage(model, "static");
  return {sampler.log_evidence(), sampler.history(), model.theta(), model.x(), sampler.log_weights()};
}

template <class Run>
void check_evidence(const char* name, Run run, double ess_rmin, double abs_tol = 0.1, Eigen::Index P = 1000, int seeds = 16) {
  const double exact = exact_log_evidence(kRecords);
  std::vector<double> z;
  std::cout << std::fixed << std::setprecision(4) << "gaussian chain, " << name << " (P=" << P
            << ", ess_rmin=" << ess_rmin << "): log Z per seed";
  for (int s = 0; s < seeds; ++s) {
    auto options = chain_options(P, 500 + static_cast<std::uint64_t>(s));
    options.ess_rmin = ess_rmin;
    z.push_back(run(options).log_z);
    std::cout << " " << z.back();
  }
  double mean = 0, var = 0;
  for (double v : z) mean += v / seeds;
  for (double v : z) var += (v - mean) * (v - mean) / (seeds - 1);
  const double se = std::sqrt(var / seeds);
  std::cout << "\n  mean " << mean << ", sd " << std::sqrt(var) << ", se " << se << ", exact " << exact << ", error "
            << mean - exact << " (" << (mean - exact) / se << " se)\n";
  CHECK(std::abs(mean - exact) < 4.0 * se);
  CHECK(std::abs(mean - exact) < abs_tol);
}

}  // namespace

TEST_CASE("one data-tempered stage per record (IBIS) reproduces the exact evidence", "[smc][engine]") {
  check_evidence("IBIS, one stage per record", run_ibis, 0.5);
}

TEST_CASE("static tempering of all records reproduces the exact evidence", "[smc][engine]") {
  check_evidence("static", run_static, 0.5);
}

TEST_CASE("evidence stays right when weights are carried instead of resampled", "[smc][engine]") {
  // Carried weights degenerate (ESS falls to a few percent of P), so the spread over seeds is
  // about twice as large; the absolute tolerance follows it.
  check_evidence("static, never resampled", run_static, 0.0, 0.25);
  check_evidence("IBIS, never resampled", run_ibis, 0.0, 0.25);
  check_evidence("static, always resampled", run_static, 1.0);
}

TEST_CASE("IBIS results are bit-identical for 1 or 2 or 3 threads", "[smc][engine]") {
  const ChainRun one = run_ibis(chain_options(257, 9, 1));
  for (int threads : {2, 3}) {
    const ChainRun many = run_ibis(chain_options(257, 9, threads));
    CHECK(many.log_z == one.log_z);
    CHECK((many.theta.array() == one.theta.array()).all());
    CHECK((many.x.array() == one.x.array()).all());
    CHECK((many.log_weights == one.log_weights).all());
  }
  // ... and a different seed gives a different run.
  CHECK(run_ibis(chain_options(257, 10, 2)).log_z != one.log_z);
}

TEST_CASE("every step hits the conditional-ESS target and the summary is consistent", "[smc][engine]") {
  auto options = chain_options(500, 3);
  std::vector<smc::StepInfo> seen;
  options.progress = [&](const smc::StageSummary&, const smc::StepInfo& step) { seen.push_back(step); };
  const ChainRun run = run_static(options);
  const smc::StageSummary& s = run.stages.at(0);
  REQUIRE(seen.size() == s.steps.size());
  REQUIRE(s.steps.size() >= 2);
  double phi = 0.0, log_z = 0.0;
  for (std::size_t k = 0; k < s.steps.size(); ++k) {
    const smc::StepInfo& step = s.steps[k];
    const bool last = k + 1 == s.steps.size();
    if (last) {
      CHECK(step.phi == 1.0);
      CHECK(step.relative_cess >= options.tempering.cess_target);
    } else {
      CHECK(std::abs(step.relative_cess - options.tempering.cess_target) <= options.tempering.tolerance);
    }
    CHECK(step.phi > phi);
    CHECK(step.phi == Approx(phi + step.delta_phi).epsilon(1e-14));
    CHECK(step.resampled == (step.ess < options.ess_rmin * 500));
    CHECK(step.mh.sweeps >= options.schedule.min_sweeps);
    CHECK(step.mh.sweeps <= options.schedule.max_sweeps);
    REQUIRE(step.mh.acceptance.size() == 2);
    for (double a : step.mh.acceptance) CHECK((a > 0.0 && a <= 1.0));
    phi = step.phi;
    log_z += step.log_evidence_increment;
  }
  CHECK(log_z == Approx(s.log_evidence_increment).epsilon(1e-12));
  std::cout << s.FullReport();
}

TEST_CASE("a NaN log-likelihood is a NumericalError naming the particle and the stage", "[smc][engine]") {
  const auto options = chain_options(64, 1);
  smc::TemperedSampler sampler(options);
  GaussianChainModel model(kRecords, 64, sampler.model_rngs());
  model.add_record(sampler.model_rngs());
  model.nan_particle = 17;
  CHECK_THROWS_AS(sampler.run_stage(model, "truck 4711"), ssrfleet::NumericalError);
  CHECK_THROWS_WITH(sampler.run_stage(model, "truck 4711"), Contains("particle 17") && Contains("truck 4711"));
}

TEST_CASE("sampler options are validated with messages naming the rule", "[smc][engine]") {
  std::string error;
  smc::TemperedSampler::Options good;
  CHECK(good.IsValid(&error));
  CHECK(good.threads >= 1);
  CHECK(good.tempering.cess_target == 0.9);
  auto bad = good;
  bad.particles = 1;
  CHECK_FALSE(bad.IsValid(&error));
  CHECK_THAT(error, Contains("particles"));
  CHECK_THROWS_AS(smc::TemperedSampler(bad), ssrfleet::UsageError);
  bad = good;
  bad.threads = 0;
  CHECK_FALSE(bad.IsValid(&error));
  CHECK_THAT(error, Contains("threads"));
  bad = good;
  bad.tempering.cess_target = 1.0;
  CHECK_FALSE(bad.IsValid(&error));
  CHECK_THAT(error, Contains("cess_target"));
  bad = good;
  bad.ess_rmin = -0.1;
  CHECK_FALSE(bad.IsValid(&error));
  bad = good;
  bad.schedule.max_sweeps = 0;
  CHECK_FALSE(bad.IsValid(&error));
  CHECK_THAT(error, Contains("max_sweeps"));
  bad = good;
  bad.schedule.sweep = {};
  CHECK_FALSE(bad.IsValid(&error));
  CHECK_THAT(error, Contains("sweep"));
  bad = good;
  bad.schedule.sweep[0].kind = smc::MoveKind::kModel;  // a model move without a name
  CHECK_FALSE(bad.IsValid(&error));
  CHECK_THAT(error, Contains("name"));

  // A model with another particle count is a usage error naming the stage.
  smc::TemperedSampler sampler(chain_options(32, 1));
  GaussianChainModel model(kRecords, 31, sampler.model_rngs());
  model.add_record(sampler.model_rngs());
  CHECK_THROWS_WITH(sampler.run_stage(model, "record 0"), Contains("record 0") && Contains("31"));
}

TEST_CASE("each MH step evaluates all proposals of a block in one call", "[smc][engine]") {
  smc::TemperedSampler sampler(chain_options(100, 2));
  GaussianChainModel model(kRecords, 100, sampler.model_rngs());
  model.add_record(sampler.model_rngs());
  const smc::StageSummary s = sampler.run_stage(model, "record 0");
  int sweeps = 0;
  for (const auto& step : s.steps) sweeps += step.mh.sweeps;
  CHECK(model.batched_calls == 2 * sweeps);  // two blocks, one call each per sweep
}

TEST_CASE("a schedule naming a model move the model lacks is a usage error naming it", "[smc][engine][schedule]") {
  auto options = chain_options(64, 1);
  smc::ScheduledMove gibbs;
  gibbs.kind = smc::MoveKind::kModel;
  gibbs.model_move = "gibbs on mu";
  options.schedule.sweep.push_back(gibbs);
  smc::TemperedSampler sampler(options);
  GaussianChainModel model(kRecords, 64, sampler.model_rngs());
  model.add_record(sampler.model_rngs());
  CHECK_THROWS_WITH(sampler.run_stage(model, "record 0"), Contains("gibbs on mu"));
}

TEST_CASE("a random walk held back by its acceptance condition is recorded as skipped", "[smc][engine][schedule]") {
  auto options = chain_options(200, 2);
  options.schedule = smc::MoveSchedule::ibis_independence(/*max_sweeps=*/6, /*final_sweeps=*/0);
  options.schedule.trigger = smc::MoveSchedule::Trigger::kEveryStep;
  smc::TemperedSampler sampler(options);
  GaussianChainModel model(kRecords, 200, sampler.model_rngs());
  model.add_record(sampler.model_rngs());
  const smc::StageSummary s = sampler.run_stage(model, "record 0");
  for (const auto& step : s.steps) {
    for (const auto& block : step.mh.block_names) {
      const smc::MoveRecord* ind = step.mh.find("independence", block);
      const smc::MoveRecord* walk = step.mh.find("random walk", block);
      REQUIRE(ind != nullptr);
      REQUIRE(walk != nullptr);
      CHECK(ind->runs == step.mh.sweeps);
      // Each sweep either ran the fallback or held it back, never both, never neither.
      CHECK(walk->runs + walk->skipped == step.mh.sweeps);
      // On a Gaussian target the t proposal fitted to the cloud is accepted above 0.3 most of the time.
      CHECK(ind->acceptance > 0.3);
    }
  }
}

TEST_CASE("move() shows each sweep's states to an observer without changing a bit", "[smc][engine][schedule]") {
  // Two samplers with one seed over the same records; one watches its final sweeps. The observer
  // must be called once per sweep, in order, with the model holding that sweep's states, and the
  // run must end where the unwatched one does.
  auto run = [](bool watch, std::vector<Eigen::MatrixXd>* seen) {
    smc::TemperedSampler sampler(chain_options(128, 9));
    GaussianChainModel model(kRecords, 128, sampler.model_rngs().child(0));
    for (std::size_t n = 0; n < 3; ++n) {
      model.add_record(sampler.model_rngs().child(1));
      sampler.run_stage(model, "record " + std::to_string(n));
    }
    smc::SweepObserver observe;
    if (watch) observe = [&](int sweep) {
      CHECK(sweep == static_cast<int>(seen->size()));
      seen->push_back(model.theta());
    };
    const smc::MhSummary s = sampler.move(model, "final", 4, observe);
    CHECK(s.sweeps == 4);
    return model.theta();
  };
  std::vector<Eigen::MatrixXd> seen;
  const Eigen::MatrixXd watched = run(true, &seen);
  const Eigen::MatrixXd unwatched = run(false, nullptr);
  CHECK(watched == unwatched);
  REQUIRE(seen.size() == 4);
  CHECK(seen.back() == watched);
  // Each sweep moved the cloud (an independence proposal accepts many particles per sweep).
  for (std::size_t k = 1; k < seen.size(); ++k) CHECK((seen[k].array() != seen[k - 1].array()).count() > 32);
}
