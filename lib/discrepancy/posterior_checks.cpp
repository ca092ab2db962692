#include "discrepancy/posterior_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <boost/random/uniform_01.hpp>

namespace ssrfleet::discrepancy {

using Eigen::Index;
using fleet::CheckKind;

namespace {

constexpr int kFamilies = static_cast<int>(CheckKind::kCount);
// The families with a value per sensor come first in CheckKind; the autocorrelation (a property
// of each truck's whole residual vector), the stiffness distribution and the latent covariates
// (of the trucks' latents) have none.
constexpr int kPerSensorFamilies = static_cast<int>(CheckKind::kAutocorrelation);
// The covariate families kSpeed, kMass, kLateral are consecutive.
constexpr int kFirstCovariate = static_cast<int>(CheckKind::kSpeed);
constexpr int kCovariates = 3;

using FamilyValues = std::array<double, kFamilies>;

constexpr int family(CheckKind kind) { return static_cast<int>(kind); }

// ---- Input validation -------------------------------------------------------------------------

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("run_checks: " + what);
}

// "name[d]", built by appending: GCC 12 reports a false -Wrestrict on "[" + std::to_string(d).
std::string indexed(const char* name, std::size_t d) {
  std::string s(name);
  s.append("[").append(std::to_string(d)).append("]");
  return s;
}

std::string shape(const Eigen::MatrixXd& m) {
  return std::to_string(m.rows()) + " x " + std::to_string(m.cols());
}

// A per-draw vector of probability integral transforms: empty, or one per draw, each a value in
// [0, 1] per truck.
void validate_pit(const std::vector<Eigen::VectorXd>& pit, const char* name, std::size_t D, Index trucks) {
  require(pit.empty() || pit.size() == D, std::string(name) + " holds " + std::to_string(pit.size()) +
                                              " draws, but model_if holds " + std::to_string(D) + " (or must be empty)");
  for (std::size_t d = 0; d < pit.size(); ++d) {
    const Eigen::VectorXd& u = pit[d];
    require(u.size() == trucks, indexed(name, d) + " has " + std::to_string(u.size()) + " entries, but observed has " +
                                    std::to_string(trucks) + " trucks");
    require((u.array() >= 0.0 && u.array() <= 1.0).all(), indexed(name, d) + " holds a value outside [0, 1]");
  }
}

void validate(const PosteriorDraws& draws, const CheckOptions& options) {
  require(options.replicates >= 1,
          "replicates is " + std::to_string(options.replicates) + ", but must be >= 1");
  require(options.alpha > 0.0 && options.alpha < 1.0,
          "alpha is " + std::to_string(options.alpha) + ", but must lie in (0, 1)");

  const Eigen::MatrixXd& y = draws.observed;
  require(y.rows() >= 1, "observed has no sensors (rows)");
  require(y.cols() >= 2,
          "observed has " + std::to_string(y.cols()) + " trucks (columns), but the checks need >= 2");
  require(y.allFinite(), "observed holds a value that is not finite");
  const auto n = std::to_string(y.cols());
  require(draws.speed_mps.size() == y.cols(), "speed_mps has " + std::to_string(draws.speed_mps.size()) +
                                                  " entries, but observed has " + n + " trucks");
  require(draws.sprung_mass_kg.size() == y.cols(), "sprung_mass_kg has " +
                                                       std::to_string(draws.sprung_mass_kg.size()) +
                                                       " entries, but observed has " + n + " trucks");

  const std::size_t D = draws.model_if.size();
  require(D >= 1, "model_if holds no posterior draws, but the checks need >= 1");
  require(draws.lateral_m.size() == D, "lateral_m holds " + std::to_string(draws.lateral_m.size()) +
                                           " draws, but model_if holds " + std::to_string(D));
  require(draws.sigma_if.size() == D, "sigma_if holds " + std::to_string(draws.sigma_if.size()) +
                                          " draws, but model_if holds " + std::to_string(D));
  for (std::size_t d = 0; d < D; ++d) {
    const Eigen::MatrixXd& f = draws.model_if[d];
    require(f.rows() == y.rows() && f.cols() == y.cols(),
            indexed("model_if", d) + " is " + shape(f) + ", but observed is " + shape(y));
    require(f.allFinite(), indexed("model_if", d) + " holds a value that is not finite");
    require(draws.lateral_m[d].size() == y.cols(), indexed("lateral_m", d) + " has " +
                                                       std::to_string(draws.lateral_m[d].size()) +
                                                       " entries, but observed has " + n + " trucks");
    require(std::isfinite(draws.sigma_if[d]) && draws.sigma_if[d] > 0.0,
            indexed("sigma_if", d) + " is " + std::to_string(draws.sigma_if[d]) + ", but must be positive");
  }
  validate_pit(draws.stiffness_pit, "stiffness_pit", D, y.cols());
  validate_pit(draws.tyre_stiffness_pit, "tyre_stiffness_pit", D, y.cols());
}

// ---- The stiffness family ----------------------------------------------------------------------

// Anderson-Darling A² of a sample's probability integral transforms against U(0, 1):
// -n - (1/n) Σ_i (2i - 1) [ln u_(i) + ln(1 - u_(n+1-i))]. It weighs the tails, where a class of
// stiffer or softer trucks shows first. E[A²] = 1 under the model, for every n.
double anderson_darling(Eigen::VectorXd u) {
  std::sort(u.data(), u.data() + u.size());
  // u of exactly 0 or 1 (a k far in a tail, Φ rounded) would give an infinite A²: clamp it to
  // the last representable tail, which still counts as a decisive failure.
  constexpr double kTiny = 1e-300;
  const Index n = u.size();
  double sum = 0.0;
  for (Index i = 0; i < n; ++i) {
    const double lo = std::max(u[i], kTiny), hi = std::max(1.0 - u[n - 1 - i], kTiny);
    sum += (2.0 * static_cast<double>(i) + 1.0) * (std::log(lo) + std::log(hi));
  }
  return -static_cast<double>(n) - sum / static_cast<double>(n);
}

// ---- The family statistics of one residual matrix ---------------------------------------------

// A covariate across trucks, centred and scaled to unit length. A residual row's Pearson
// correlation with the covariate is then the row's centred dot product with this direction over
// the row's centred norm, so all three covariates cost one small matrix product. A constant
// covariate has no direction: zeros make its correlations 0 (a vacuous check rather than NaN).
Eigen::VectorXd unit_direction(const Eigen::VectorXd& x) {
  Eigen::VectorXd u = x.array() - x.mean();
  const double norm = u.norm();
  return norm > 0.0 ? Eigen::VectorXd(u / norm) : Eigen::VectorXd::Zero(x.size());
}

// Evaluates every residual family's statistic T on a residual matrix (sensors x trucks), keeping the
// per-sensor values behind it. It is run once per posterior draw on the observed residuals and
// once per replicate, so it owns its workspace and allocates nothing per call.
class ResidualStatistics {
 public:
  ResidualStatistics(const Eigen::VectorXd& speed_mps, const Eigen::VectorXd& sprung_mass_kg, Index sensors)
      : per_sensor(sensors, kPerSensorFamilies),
        directions_(speed_mps.size(), kCovariates),
        sensor_centred_(sensors, speed_mps.size()),
        truck_mean_(speed_mps.size()),
        truck_centred_(sensors, speed_mps.size()),
        sensor_ss_(sensors) {
    directions_.col(0) = unit_direction(speed_mps);
    directions_.col(1) = unit_direction(sprung_mass_kg);
  }

  // r: residuals; sigma: the draw's σ; lateral: unit_direction of the draw's lateral positions.
  void evaluate(const Eigen::MatrixXd& r, double sigma, const Eigen::Ref<const Eigen::VectorXd>& lateral) {
    const auto N = static_cast<double>(r.cols());
    directions_.col(2) = lateral;

    auto mean = per_sensor.col(family(CheckKind::kSensorMean));
    auto dispersion = per_sensor.col(family(CheckKind::kSensorDispersion));
    auto correlation = per_sensor.middleCols(kFirstCovariate, kCovariates);

    row_mean.noalias() = r.rowwise().mean();
    sensor_centred_ = r.colwise() - row_mean;
    sensor_ss_ = sensor_centred_.rowwise().squaredNorm();

    // Under the model mean_i r_im ~ N(0, σ²/N), so z_m is standard normal.
    mean = row_mean * (std::sqrt(N) / sigma);
    // Under the model N ρ_m ~ χ²_{N-1}: ρ_m ≈ 1 and a noisy sensor lifts it.
    dispersion = sensor_ss_ / (N * sigma * sigma);
    correlation.noalias() = sensor_centred_ * directions_;
    for (Index m = 0; m < r.rows(); ++m) {
      // A sensor whose residuals are all equal correlates with nothing.
      const double norm = std::sqrt(sensor_ss_[m]);
      if (norm > 0.0) {
        correlation.row(m) /= norm;
      } else {
        correlation.row(m).setZero();
      }
    }

    T[family(CheckKind::kSensorMean)] = mean.cwiseAbs().maxCoeff();
    T[family(CheckKind::kSensorDispersion)] = dispersion.maxCoeff();
    // Each c_m is about N(0, 1/N) under the model and the sensors' rows are independent, so
    // N Σ_m c_m² is about χ²_M.
    for (int k = 0; k < kCovariates; ++k) T[kFirstCovariate + k] = N * correlation.col(k).squaredNorm();
    T[family(CheckKind::kAutocorrelation)] = autocorrelation_statistic(r);
  }

  FamilyValues T{};
  Eigen::MatrixXd per_sensor;  // sensors x kPerSensorFamilies, columns in CheckKind order
  Eigen::VectorXd row_mean;    // per sensor: mean_i r_im

 private:
  // |ā + 1/M| sqrt(N (M - 1)), ā the mean over trucks of the lag-1 autocorrelation of each
  // truck's residuals along the array, centred on the truck's own mean. For white noise of any
  // variance the centred vector's direction is uniform on the sphere orthogonal to 1 and
  // independent of its length, so E[a_i] = tr(P A)/(M - 1) = -1/M exactly (P the centring
  // projector, A the symmetrised lag-1 shift). Centring there makes the test two-sided about the
  // model's value; the scale makes T about |N(0, 1)|.
  double autocorrelation_statistic(const Eigen::MatrixXd& r) {
    const Index M = r.rows(), N = r.cols();
    if (M < 2) return 0.0;  // no neighbours: nothing to test
    const double null_mean = -1.0 / static_cast<double>(M);
    truck_mean_.noalias() = r.colwise().mean();
    truck_centred_ = r.rowwise() - truck_mean_;
    double sum = 0.0;
    for (Index i = 0; i < N; ++i) {
      const auto c = truck_centred_.col(i);
      const double ss = c.squaredNorm();
      // A flat residual vector carries no evidence either way: count it at the model's value.
      sum += ss > 0.0 ? c.head(M - 1).dot(c.tail(M - 1)) / ss : null_mean;
    }
    const double mean_autocorrelation = sum / static_cast<double>(N);
    return std::abs(mean_autocorrelation - null_mean) * std::sqrt(static_cast<double>(N * (M - 1)));
  }

  Eigen::MatrixXd directions_;      // trucks x 3: unit directions of speed, mass, lateral
  Eigen::MatrixXd sensor_centred_;  // r with each sensor's mean over trucks removed
  Eigen::RowVectorXd truck_mean_;   // per truck: mean_m r_im
  Eigen::MatrixXd truck_centred_;   // r with each truck's mean over sensors removed
  Eigen::VectorXd sensor_ss_;       // per sensor: Σ_i (r_im - r̄_m)²
};

// ---- The latent-covariate family ---------------------------------------------------------------

// The four pairs the family tests, in the order of LatentCovariates::correlation.
constexpr int kLatentPairs = 4;
constexpr const char* kLatentPairNames[kLatentPairs] = {"k against speed", "k against sprung mass",
                                                        "k_t against speed", "k_t against sprung mass"};

// T = N max c² over (k, k_t) x (speed, sprung mass), c the Pearson correlation of a stiffness's
// PIT values with the covariate. Each N c² is about χ²_1 under the model; the replicates give the
// maximum's exact reference distribution for these trucks' covariates (which are fixed, so their
// own correlation is accounted for). A missing PIT vector leaves its pairs at c = 0.
class LatentCovariates {
 public:
  LatentCovariates(const Eigen::VectorXd& speed_mps, const Eigen::VectorXd& sprung_mass_kg)
      : directions_(speed_mps.size(), 2), centred_(speed_mps.size()) {
    directions_.col(0) = unit_direction(speed_mps);
    directions_.col(1) = unit_direction(sprung_mass_kg);
  }

  // k_pit, tyre_pit: one draw's PIT values, or null when absent. Returns T.
  double evaluate(const Eigen::VectorXd* k_pit, const Eigen::VectorXd* tyre_pit) {
    correlation.setZero();
    add(k_pit, 0);
    add(tyre_pit, 2);
    return static_cast<double>(directions_.rows()) * correlation.cwiseAbs2().maxCoeff();
  }

  Eigen::Vector4d correlation = Eigen::Vector4d::Zero();  // signed c of each pair, last evaluate()

 private:
  void add(const Eigen::VectorXd* u, int first) {
    if (u == nullptr) return;
    centred_ = u->array() - u->mean();
    const double norm = centred_.norm();
    if (!(norm > 0.0)) return;  // every truck at one quantile: correlates with nothing
    correlation.segment<2>(first).noalias() = directions_.transpose() * centred_ / norm;
  }

  Eigen::MatrixXd directions_;  // trucks x 2: unit directions of speed and sprung mass
  Eigen::VectorXd centred_;
};

const Eigen::VectorXd* pit_of(const std::vector<Eigen::VectorXd>& pit, std::size_t d) {
  return pit.empty() ? nullptr : &pit[d];
}

// ---- Observed data, replicated data, and the gap measures -------------------------------------

// The observed residuals under every draw: T_obs(d), and the posterior means of the values behind.
struct ObservedStatistics {
  std::vector<FamilyValues> T_by_draw;
  Eigen::MatrixXd per_sensor_mean;  // sensors x kPerSensorFamilies
  Eigen::VectorXd residual_mean;    // per sensor: posterior mean of mean_i r_im
  Eigen::Vector4d latent_correlation_mean = Eigen::Vector4d::Zero();   // posterior mean of each pair's c
  Eigen::Vector4d latent_statistic_mean = Eigen::Vector4d::Zero();     // posterior mean of each pair's N c²
};

ObservedStatistics evaluate_observed(const PosteriorDraws& draws, const Eigen::MatrixXd& lateral_directions,
                                     ResidualStatistics& stats, LatentCovariates& latent) {
  const std::size_t D = draws.model_if.size();
  ObservedStatistics out;
  out.T_by_draw.resize(D);
  out.per_sensor_mean = Eigen::MatrixXd::Zero(draws.observed.rows(), kPerSensorFamilies);
  out.residual_mean = Eigen::VectorXd::Zero(draws.observed.rows());
  Eigen::MatrixXd residual(draws.observed.rows(), draws.observed.cols());
  for (std::size_t d = 0; d < D; ++d) {
    residual = draws.observed - draws.model_if[d];
    stats.evaluate(residual, draws.sigma_if[d], lateral_directions.col(static_cast<Index>(d)));
    out.T_by_draw[d] = stats.T;
    out.T_by_draw[d][family(CheckKind::kStiffnessDistribution)] =
        draws.stiffness_pit.empty() ? 0.0 : anderson_darling(draws.stiffness_pit[d]);
    out.T_by_draw[d][family(CheckKind::kLatentCovariates)] =
        latent.evaluate(pit_of(draws.stiffness_pit, d), pit_of(draws.tyre_stiffness_pit, d));
    out.latent_correlation_mean += latent.correlation;
    out.latent_statistic_mean += static_cast<double>(draws.observed.cols()) * latent.correlation.cwiseAbs2();
    out.per_sensor_mean += stats.per_sensor;
    out.residual_mean += stats.row_mean;
  }
  out.per_sensor_mean /= static_cast<double>(D);
  out.residual_mean /= static_cast<double>(D);
  out.latent_correlation_mean /= static_cast<double>(D);
  out.latent_statistic_mean /= static_cast<double>(D);
  return out;
}

// What the replicates add up to, per family.
struct ReplicateTally {
  std::array<int, kFamilies> at_least_observed{};  // #{T_rep >= T_obs}
  FamilyValues observed_sum{}, replicated_sum{};
};

ReplicateTally replicate(const PosteriorDraws& draws, const Eigen::MatrixXd& lateral_directions,
                         const ObservedStatistics& observed, const CheckOptions& options,
                         ResidualStatistics& stats, LatentCovariates& latent) {
  const std::size_t D = draws.model_if.size();
  boost::random::mt19937_64 engine(options.seed);
  boost::random::normal_distribution<double> std_normal(0.0, 1.0);
  // The stiffness replicates have a stream of their own, so the residual families' replicates
  // are the same with or without them.
  boost::random::mt19937_64 fleet_engine(options.seed ^ 0x666c656574ULL /* "fleet" */);
  // And the latent-covariate replicates theirs: adding the family changed no other family's p.
  boost::random::mt19937_64 covariate_engine(options.seed ^ 0x6c6174636f76ULL /* "latcov" */);
  boost::random::uniform_01<double> uniform;
  Eigen::VectorXd u(draws.observed.cols()), u_k(draws.observed.cols()), u_kt(draws.observed.cols());
  Eigen::MatrixXd residual(draws.observed.rows(), draws.observed.cols());
  ReplicateTally tally;
  for (int r = 0; r < options.replicates; ++r) {
    const std::size_t d = static_cast<std::size_t>(r) % D;
    const double sigma = draws.sigma_if[d];
    // y_rep - f_d = σ_d ε: draw the residual itself rather than form y_rep and subtract f_d
    // again (equal in exact arithmetic, without f's rounding). Fixed order: reproducible.
    for (Index i = 0; i < residual.cols(); ++i) {
      for (Index m = 0; m < residual.rows(); ++m) residual(m, i) = sigma * std_normal(engine);
    }
    stats.evaluate(residual, sigma, lateral_directions.col(static_cast<Index>(d)));
    FamilyValues T_rep = stats.T;
    if (!draws.stiffness_pit.empty()) {
      for (Index i = 0; i < u.size(); ++i) u[i] = uniform(fleet_engine);
      T_rep[family(CheckKind::kStiffnessDistribution)] = anderson_darling(u);
    }
    const bool has_k = !draws.stiffness_pit.empty(), has_kt = !draws.tyre_stiffness_pit.empty();
    if (has_k || has_kt) {
      // A fresh fleet's (k, k_t) quantiles: iid U(0, 1), whatever the trucks' speeds and masses.
      for (Index i = 0; i < u_k.size(); ++i) {
        u_k[i] = uniform(covariate_engine);
        u_kt[i] = uniform(covariate_engine);
      }
      T_rep[family(CheckKind::kLatentCovariates)] = latent.evaluate(has_k ? &u_k : nullptr, has_kt ? &u_kt : nullptr);
    }
    const FamilyValues& T_obs = observed.T_by_draw[d];
    for (int k = 0; k < kFamilies; ++k) {
      tally.observed_sum[k] += T_obs[k];
      tally.replicated_sum[k] += T_rep[k];
      if (T_rep[k] >= T_obs[k]) ++tally.at_least_observed[k];
    }
  }
  return tally;
}

std::vector<double> to_std_vector(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }

CheckResult make_result(CheckKind kind, const ObservedStatistics& observed, const ReplicateTally& tally,
                        const CheckOptions& options) {
  const int k = family(kind);
  const auto R = static_cast<double>(options.replicates);
  CheckResult out;
  out.kind = kind;
  out.statistic = tally.observed_sum[k] / R;
  out.replicated = tally.replicated_sum[k] / R;
  // Counting the observed data among the replicates keeps p > 0 and makes it a valid p-value
  // for finite R (Davison & Hinkley 1997, §4.2).
  out.p_value = (1.0 + tally.at_least_observed[k]) / (1.0 + R);
  out.flagged = out.p_value < options.alpha;
  if (k < kPerSensorFamilies) {
    const Eigen::VectorXd values = observed.per_sensor_mean.col(k);
    out.per_sensor = to_std_vector(values);
    // Largest in magnitude: z_m and c_m are signed; ρ_m >= 0, so for it this is the plain largest.
    Index worst = 0;
    values.cwiseAbs().maxCoeff(&worst);
    out.sensor = static_cast<int>(worst) + 1;
  }
  if (kind == CheckKind::kLatentCovariates && observed.latent_statistic_mean.maxCoeff() > 0.0) {
    // The pair with the largest mean N c², and its posterior mean correlation.
    Index pair = 0;
    observed.latent_statistic_mean.maxCoeff(&pair);
    std::ostringstream detail;
    detail << "largest: " << kLatentPairNames[pair] << ", correlation " << std::showpos << std::fixed
           << std::setprecision(2) << observed.latent_correlation_mean[pair] << " (posterior mean)";
    out.detail = detail.str();
  }
  return out;
}

// The share of y_im inside the central 95 % interval of its posterior predictive distribution,
// the mixture over draws of N(f_im(d), σ_d²): inside iff the mixture CDF at y_im lies in
// [0.025, 0.975]. Exact for the draws given, with no sampling of the noise.
double coverage95(const PosteriorDraws& draws) {
  const Eigen::MatrixXd& y = draws.observed;
  Eigen::MatrixXd cdf = Eigen::MatrixXd::Zero(y.rows(), y.cols());
  for (std::size_t d = 0; d < draws.model_if.size(); ++d) {
    const double scale = -1.0 / (std::sqrt(2.0) * draws.sigma_if[d]);
    const Eigen::MatrixXd& f = draws.model_if[d];
    for (Index i = 0; i < y.cols(); ++i) {
      for (Index m = 0; m < y.rows(); ++m) cdf(m, i) += 0.5 * std::erfc((y(m, i) - f(m, i)) * scale);  // Φ
    }
  }
  cdf /= static_cast<double>(draws.model_if.size());
  const auto inside = (cdf.array() >= 0.025 && cdf.array() <= 0.975).count();
  return static_cast<double>(inside) / static_cast<double>(cdf.size());
}

GapMeasures gap_measures(const PosteriorDraws& draws, const ObservedStatistics& observed) {
  // A plain loop, not a mapped Eigen mean: Eigen vectorises a sum over a mapped pointer from its
  // first aligned element, so the last bits would follow the vector's heap address, which differs
  // with the thread count (found by the thread-count test of diagnose).
  double sigma_sum = 0.0;
  for (const double s : draws.sigma_if) sigma_sum += s;
  const double sigma_mean = sigma_sum / static_cast<double>(draws.sigma_if.size());
  const Eigen::VectorXd standardised =
      observed.residual_mean * (std::sqrt(static_cast<double>(draws.observed.cols())) / sigma_mean);
  GapMeasures out;
  out.mean_residual = to_std_vector(observed.residual_mean);
  out.standardised_mean = to_std_vector(standardised);
  out.rms_standardised_mean =
      std::sqrt(standardised.squaredNorm() / static_cast<double>(standardised.size()));
  out.systematic_gap = std::sqrt(std::max(0.0, out.rms_standardised_mean * out.rms_standardised_mean - 1.0));
  out.coverage95 = coverage95(draws);
  double stiffness = 0.0;
  for (const FamilyValues& T : observed.T_by_draw) stiffness += T[family(CheckKind::kStiffnessDistribution)];
  out.stiffness_distribution = stiffness / static_cast<double>(observed.T_by_draw.size());
  return out;
}

}  // namespace

CheckReport run_checks(const PosteriorDraws& draws, const CheckOptions& options) {
  validate(draws, options);
  const auto D = static_cast<Index>(draws.model_if.size());
  Eigen::MatrixXd lateral_directions(draws.observed.cols(), D);
  for (Index d = 0; d < D; ++d)
    lateral_directions.col(d) = unit_direction(draws.lateral_m[static_cast<std::size_t>(d)]);

  ResidualStatistics stats(draws.speed_mps, draws.sprung_mass_kg, draws.observed.rows());
  LatentCovariates latent(draws.speed_mps, draws.sprung_mass_kg);
  const ObservedStatistics observed = evaluate_observed(draws, lateral_directions, stats, latent);
  const ReplicateTally tally = replicate(draws, lateral_directions, observed, options, stats, latent);

  CheckReport report;
  for (int k = 0; k < kFamilies; ++k)
    report.checks.push_back(make_result(static_cast<CheckKind>(k), observed, tally, options));
  report.gap = gap_measures(draws, observed);
  return report;
}

}  // namespace ssrfleet::discrepancy
