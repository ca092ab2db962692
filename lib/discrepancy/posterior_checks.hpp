// Posterior predictive checks of a fitted fleet model (Gelman, Meng & Stern 1996; BDA3 §6.3):
// where do the model and the weigh-in-motion measurements disagree? The observation model is
// y_im = f_im + N(0, σ²) for truck i at sensor m, so under the model the residuals
// r_im = y_im - f_im are white noise of sd σ. Each check family (fleet::CheckKind) reduces a
// residual matrix to one statistic T that grows when one kind of structure is present:
//
//   kSensorMean        T = max_m |z_m|, z_m = mean_i r_im / (σ / sqrt N)      (a sensor's offset)
//   kSensorDispersion  T = max_m ρ_m, ρ_m = (1/N) Σ_i (r_im - r̄_m)² / σ²    (a noisy sensor)
//   kSpeed, kMass,     T = N Σ_m c_m², c_m = corr_i(x_i, r_im), x = speed, sprung mass or the
//   kLateral           draw's lateral position (T ≈ χ²_M under the model)
//   kAutocorrelation   T = |ā + 1/M| sqrt(N (M - 1)), ā = mean over trucks of the lag-1
//                      autocorrelation of r_i· along the array, centred on the truck's mean
//                      (-1/M is its exact mean for white noise, so T is two-sided about it)
//   kStiffnessDistribution  T = A², the Anderson-Darling statistic of u_i = F(k_i | θ, ψ), each
//                      truck's suspension stiffness under the draw's fleet distribution,
//                      against U(0, 1) (a second class of trucks, say, bunches the u_i)
//   kLatentCovariates  T = N max c², c = corr_i(u_i, x_i) over the four pairs of u = F(k_i | θ, ψ) or
//                      F(k_t,i | θ) with x = speed or sprung mass. The model draws every truck's
//                      (k, k_t) from one fleet distribution whatever its speed and load; a stiffness
//                      that changes with either (a progressive spring under a heavier load, a tyre
//                      stiffer at speed) is absorbed by each truck's own latents, so the residual
//                      families cannot see it, but the latents then follow the covariate. One
//                      posterior draw's u are iid U(0, 1) independent of the covariates under the
//                      model (a pivotal quantity: Johnson 2007), so the test is exact per draw.
//
// The p-value compares T on the observed data with T on data replicated from the posterior:
// replicate r uses draw d = r mod D and y_rep = f_d + σ_d ε with fresh ε, and
// p = (1 + #{T_rep >= T_obs(d)}) / (1 + R). For the stiffness and latent-covariate families the
// replicate is a fresh fleet of N trucks from the draw's distribution, whose u_i are iid U(0, 1)
// whatever θ and ψ, and independent of the trucks' speeds and masses.
// These realised discrepancies of the latents (Gelman, Meng & Stern 1996, §2.3) are
// conservative: the posterior pulls each k_i towards the fleet distribution. A small p flags the family; the per-sensor values
// behind T say where. The gap measures summarise the per-sensor mean misfit and the calibration
// of the 95 % predictive intervals, for reports.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/model_extension.hpp"

namespace ssrfleet::discrepancy {

// Posterior draws of what the checks need (equal-weight draws, e.g. resampled particles).
struct PosteriorDraws {
  Eigen::MatrixXd observed;                // y: sensors x trucks
  Eigen::VectorXd speed_mps;               // per truck
  Eigen::VectorXd sprung_mass_kg;          // per truck
  std::vector<Eigen::MatrixXd> model_if;   // per draw: f, sensors x trucks, at that draw's latents
  std::vector<Eigen::VectorXd> lateral_m;  // per draw: each truck's lateral position
  std::vector<double> sigma_if;            // per draw: σ
  // per draw: F(k_i | θ, ψ) of every truck's k under the draw's fleet distribution. Empty: the
  // stiffness family is vacuous (T = 0, p = 1).
  std::vector<Eigen::VectorXd> stiffness_pit;
  // per draw: F(k_t,i | θ) of every truck's tyre stiffness. Empty: the latent-covariate family
  // uses k alone (and is vacuous when stiffness_pit is empty too).
  std::vector<Eigen::VectorXd> tyre_stiffness_pit;
};

struct CheckResult {
  fleet::CheckKind kind;
  double statistic = 0.0;          // the family statistic T on the observed data, averaged over draws
  double replicated = 0.0;         // the mean of T on replicated data
  double p_value = 1.0;            // posterior predictive p-value of the family statistic
  bool flagged = false;            // p_value < alpha
  int sensor = 0;                  // 1-based sensor where the statistic is largest (0 if not per sensor)
  std::vector<double> per_sensor;  // the per-sensor values behind T (empty if not per sensor)
  // Where a family without sensors points, in words (the latent-covariate family: which stiffness
  // against which covariate, and the posterior mean correlation); empty otherwise.
  std::string detail;
};

struct GapMeasures {
  std::vector<double> mean_residual;  // per sensor: posterior mean of (1/N) Σ_i (y_im - f_im)
  std::vector<double> standardised_mean;  // per sensor: mean_residual / (σ̄ / sqrt(N)), σ̄ = posterior mean σ
  double rms_standardised_mean = 0.0;  // RMS over sensors of standardised_mean
  // The systematic part of that gap: sqrt(max(0, rms² - 1)). Noise alone gives each
  // standardised mean an expected square of 1 (a little less once the trucks' latents are
  // fitted), so a right model scores about 0 here, while the raw RMS never falls below about 1;
  // "the gap shrinks by half" is judged on this part.
  double systematic_gap = 0.0;
  double coverage95 = 0.0;             // share of y_im inside its posterior predictive 95 % interval
  // The fleet level: the posterior mean of the stiffness family's A² (about 1 when the trucks'
  // k look like draws from the fleet distribution; 0 without stiffness_pit).
  double stiffness_distribution = 0.0;
};

struct CheckReport {
  std::vector<CheckResult> checks;  // one per CheckKind, in enum order
  GapMeasures gap;
};

struct CheckOptions {
  int replicates = 4000;  // replicated data sets (draws taken cyclically, each with fresh noise)
  double alpha = 0.01;    // flag threshold per family
  std::uint64_t seed = 1;
};

// Runs every check family and the gap measures. Random numbers come from one Boost mt19937_64
// seeded with options.seed, so the same draws and options give the same report. Cost
// O(R M N + D M N). Throws std::invalid_argument on inconsistent sizes (naming which), fewer than
// 2 trucks or 1 draw, a σ that is not positive, or bad options.
CheckReport run_checks(const PosteriorDraws& draws, const CheckOptions& options);

}  // namespace ssrfleet::discrepancy
