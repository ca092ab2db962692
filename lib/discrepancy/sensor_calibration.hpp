// Per-site sensor calibration fitted beside the fleet (docs/sites.md).
// A site's sensor j may read g_j times the true impact factor. The marginal core's tables hold the
// base forward model at the data as logged, so the gains cannot ride in its particles; they are fitted
// by Monte Carlo EM around it instead:
//   E-step  a fit of every site with the current gains divided out of the records, then each truck's
//           latents drawn from p(x_i | y_i, θ) for posterior draws of θ (marginal_draws.hpp), which
//           give the model's impact factors μ_ij of truck i at sensor j;
//   M-step  the gain that best explains the corrected data given those latents: with
//           y_ij = g_j μ_ij + ε_ij, ε ~ N(0, σ_IF²), ĝ_j = Σ_i y_ij μ_ij / Σ_i μ_ij² per draw,
//           averaged over the draws with weights 1/σ_IF² (the complete-data maximum).
// The gains are multiplied into the current ones and the fit is run again, until no gain moves by
// more than a fraction of its standard error. The fixed point is the gains' maximum likelihood with
// θ and every truck's latents integrated out; the fleet posterior is then conditional on it.
// The standard error of a gain combines the draws by Rubin's rules for multiple imputation:
// T = W + (1 + 1/D) B, W the mean complete-data variance σ²/Σ μ², B the variance between draws
// (the information the latents' uncertainty takes away).
// Identification: a sensor's mean impact factor over a site's trucks is fixed by the measured road
// and the fleet, so each gain is identified against the others and against 1; a gain the road cannot
// tell from a stiffer fleet would show as a large standard error.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "discrepancy/marginal_draws.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/online_fit.hpp"
#include "records/wim_record.hpp"

namespace ssrfleet::discrepancy {

// One site's gains, one per sensor: the estimate and its standard error.
struct SensorGains {
  Eigen::VectorXd gain;
  Eigen::VectorXd se;
  long trucks = 0;  // the site's trucks the estimate comes from
};

// The M-step: each site's gains relative to the data the fit saw (1 where it is calibrated already),
// from options.draws posterior draws of θ with every truck's latents drawn through its own site.
// One entry per site of the fit's target, in its order; a site without trucks gets gains 1 and an
// infinite standard error. Same result for any options.threads. UsageError on bad options, or if the
// fit is not on the marginal core (whose tables the latents are drawn from).
std::vector<SensorGains> estimate_sensor_gains(const fleet::OnlineFit& fit, const MarginalDrawOptions& options);

struct CalibrationOptions {
  int max_rounds = 8;        // fits in all, the first one included
  // Converged when every gain's step |ĝ - 1| is below this many of its standard errors. The EM steps
  // shrink geometrically (by about half a round on two simulated sites with miscalibrated sensors), so what
  // is left beyond the last step is about as much again. The steps carry Monte Carlo noise of
  // sqrt(B / D) (B the between-draw variance, at most T): with D = 100 draws at most 0.1 se a gain,
  // about 0.25 se for the largest of 24 gains, which this tolerance stays above.
  double tolerance_se = 0.3;
  MarginalDrawOptions draws{.draws = 100, .mh_steps = 8, .seed = 1, .threads = 1};
};

struct CalibrationRound {
  std::vector<SensorGains> step;  // the M-step's gains relative to this round's corrected data
  double largest_step_se = 0.0;   // max over sites and sensors of |ĝ - 1| / se
};

struct CalibratedFit {
  std::unique_ptr<fleet::OnlineFit> fit;  // the last round's fit, on data corrected by `gains`
  std::vector<Eigen::VectorXd> gains;     // per site: the gains divided out of its records
  std::vector<Eigen::VectorXd> se;        // per site: their standard errors (the last M-step's)
  std::vector<CalibrationRound> rounds;
  bool converged = false;
};

// Runs the EM: `fit_records` fits the records it is given (already corrected) on the marginal core
// and returns the fit (for example fit --sites' driver). `initial` holds each site's starting gains
// (a manifest's known calibration, or ones), which the records passed in have NOT had divided out.
// `after_round` (optional) is told each round as it ends, for progress.
// UsageError on bad options, or if the fit is not on the marginal core.
using FitRecords = std::function<std::unique_ptr<fleet::OnlineFit>(const std::vector<records::WimRecord>&)>;
CalibratedFit fit_with_sensor_calibration(const std::vector<records::WimRecord>& records,
                                          std::vector<Eigen::VectorXd> initial, const FitRecords& fit_records,
                                          const CalibrationOptions& options,
                                          const std::function<void(int, const CalibrationRound&)>& after_round = {});

}  // namespace ssrfleet::discrepancy
