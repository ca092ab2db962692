#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "model/truck_search.hpp"
#include "model/truck_table.hpp"

namespace ssrfleet::model {

using detail::check_inputs;
using detail::Fitter;

namespace {
// A fit whose noise estimate exceeds this multiple of σ_ref searches again from a wide grid.
constexpr double kPoorFitRatio = 1.5;
}  // namespace

TruckFit fit_truck(const site::Site& site, double speed_mps, double sprung_mass_kg,
                   const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const TruckTableOptions& options) {
  check_inputs(site, impact_factors);
  Fitter fitter{site, speed_mps, sprung_mass_kg, impact_factors, 0, detail::active_edit(options)};
  // Coarse start: every lateral line at a 3 x 3 spread of (k, k_t) around the hint. The
  // z-likelihood is multimodal across the road; the stiffnesses only shift its modes a little.
  std::vector<double> ks, kts;
  if (options.start_is_close) {
    ks.push_back(options.k_start_npm);
    kts.push_back(options.kt_start_npm);
  } else {
    for (double fk : {0.6, 1.0, 1.6}) {
      for (double fkt : {0.7, 1.0, 1.4}) {
        ks.push_back(options.k_start_npm * fk);
        kts.push_back(options.kt_start_npm * fkt);
      }
    }
  }
  double k0 = 0.0, kt0 = 0.0;
  auto [z0, ssr0] = fitter.scan_lines(ks, kts, &k0, &kt0);
  auto [best, best_ssr] = fitter.optimise({std::log(k0), std::log(kt0), z0}, ssr0);
  // At the fitted stiffnesses a different lateral mode may win: rescan once and refit from it.
  double kr = 0.0, ktr = 0.0;
  auto [zr, ssr_r] = fitter.scan_lines({std::exp(best.log_k)}, {std::exp(best.log_kt)}, &kr, &ktr);
  if (ssr_r < best_ssr && std::abs(zr - best.z) > site.surface().dy_m) {
    auto [p2, s2] = fitter.optimise({best.log_k, best.log_kt, zr}, ssr_r);
    if (s2 < best_ssr) {
      best = p2;
      best_ssr = s2;
    }
  }

  // A fit far worse than the noise the tables expect (σ_ref) has most likely stopped in a local
  // optimum: a truck far from the hint (a stiff second class, k twice the fleet's) is out of the
  // coarse spread's reach, and its z then lands on another lateral mode. Search again from a grid
  // over the whole range of suspensions and tyres; keep what fits better. For a truck the model
  // describes, sigma_hat² / σ² is χ²(M - 3) / (M - 3): above kPoorFitRatio² (with M = 16) for
  // about 0.6 % of trucks, so the extra passes are paid rarely.
  if (std::sqrt(best_ssr / std::max(1, static_cast<int>(impact_factors.size()) - 3)) >
      kPoorFitRatio * options.sigma_ref) {
    std::vector<double> wide_k, wide_kt;
    for (double k : {150e3, 250e3, 400e3, 650e3, 1.0e6, 1.6e6}) {
      for (double kt : {0.7e6, 1.1e6, 1.7e6, 2.6e6, 4.0e6}) {
        wide_k.push_back(k);
        wide_kt.push_back(kt);
      }
    }
    double kw = 0.0, ktw = 0.0;
    auto [zw, ssr_w] = fitter.scan_lines(wide_k, wide_kt, &kw, &ktw);
    auto [pw, sw] = fitter.optimise({std::log(kw), std::log(ktw), zw}, ssr_w);
    if (sw < best_ssr) {
      best = pw;
      best_ssr = sw;
    }
  }

  TruckFit fit;
  fit.stiffness_npm = std::exp(best.log_k);
  fit.tyre_stiffness_npm = std::exp(best.log_kt);
  fit.lateral_m = best.z;
  fit.ssr = best_ssr;
  const int M = static_cast<int>(impact_factors.size());
  fit.sigma_hat = std::sqrt(best_ssr / std::max(1, M - 3));
  // Curvature: the likelihood covariance of (k, k_t, z) at σ is σ² (JᵀJ)⁻¹, J in natural units.
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  fitter.residual_and_jacobian(best, r, J);
  J.col(0) /= fit.stiffness_npm;
  J.col(1) /= fit.tyre_stiffness_npm;
  const Eigen::Matrix3d JtJ = J.transpose() * J;
  Eigen::Matrix3d cov = JtJ.ldlt().solve(Eigen::Matrix3d::Identity());
  if (!cov.allFinite() || cov(0, 0) <= 0.0 || cov(1, 1) <= 0.0) {
    // A degenerate fit (k or k_t has no effect on these sensors): a generic 20 % spread.
    cov.setZero();
    cov(0, 0) = std::pow(0.2 * fit.stiffness_npm / 0.02, 2);
    cov(1, 1) = std::pow(0.2 * fit.tyre_stiffness_npm / 0.02, 2);
  }
  fit.stiffness_sd_per_sigma = std::sqrt(cov(0, 0));
  fit.tyre_stiffness_sd_per_sigma = std::sqrt(cov(1, 1));
  fit.stiffness_correlation = cov(0, 1) / std::sqrt(cov(0, 0) * cov(1, 1));
  fit.passes = fitter.passes;
  return fit;
}


}  // namespace ssrfleet::model
