// One truck's likelihood with its lateral position integrated out, tabulated on the (k, k_t)
// lattice that every truck shares (docs/inference.md: the marginal is what keeps the per-truck
// cost from growing with n). Built once, by the quarter-car integrator, when the truck
// arrives; from then on the truck's marginal likelihood ℓ_i(θ) is a short sum over its nodes
// (fleet_marginal.hpp), with no integrator call.
//
// What a node holds. At node g = (k_g, kt_g) the 16 impact factors are linear in the road input,
// and the road is linear in z between two surface lines, so SSR_g(z) = Σ_m (y_m - IF_m(z))² is
// piecewise quadratic in z. With u = 1/σ_IF² the z-integral of the data density is
//   I_g(u) = ∫ exp(-u SSR_g(z) / 2) dz,
// computed here by Gauss–Legendre quadrature on every segment between lines in a window around
// the truck's best lateral position. Its dependence on σ_IF is carried by the Laplace form
//   log I_g(u) ≈ c_g - m_g u / 2 - b_g log u,
// whose three numbers match log I_g, its first and its second u-derivative at u_ref (the
// derivatives are the mean and variance of SSR under the z-posterior). For a quadratic bowl in z
// it is exact at every u (m = SSR_min, b = ½); elsewhere it is exact to second order at u_ref.
// The lateral prior N(z | Z, σ_z²) enters through the node's z-posterior mean ẑ_g(u) and variance
// s²_g(u) (moment matching: ∫ f(z) N(z | Z, σ_z²) dz = I · N(ẑ | Z, σ_z² + s²) for a Gaussian f).
// Both move with σ_IF where SSR_g(z) is not a quadratic bowl, so a node stores them at u_ref with
// their slopes, from the same quadrature (the u-derivative of a z-posterior moment is its
// covariance with -SSR/2), and FleetMarginal evaluates, with x = u / u_ref - 1,
//   ẑ_g(u) = ẑ_g + x ẑ'_g,   s²_g(u) = (u_ref / u) (s²_g + x v'_g),
// ẑ'_g = u_ref dẑ/du and v'_g = d(u s²) / du at u_ref: the bowl's s² ∝ 1/u exactly, v'_g = 0 there.
//
// Pieces. Where the sensors leave a truck's z broad and many-peaked across the lane (road AS2: a
// node's z-posterior sd up to 0.66 m against σ_z = 0.35 m), one Gaussian per node is not enough:
// the matched form was off by 0.1-0.2 nats per truck and biased σ_z by 20 posterior sd. Such a
// node's z-range is cut into pieces, each with its own (c, m, b, ẑ, s²), and the node sum adds
// them: ∫ f N = Σ_p ∫_p f N, each piece matched on its own (moments and slopes per piece). A node narrower than the limit (road
// AS1: all of them) stays one entry, so its bits and cost do not change.
// Which nodes. Those whose log I_g(u_ref) is within `keep_nats` of the best node's: the rest
// carry less than ~e^-keep_nats of the truck's likelihood and are dropped.
// Files: the best-fit search is truck_fit.cpp, the table build and the brute-force reference are
// truck_table.cpp; what they share (batched passes, the fitter) is truck_search.hpp.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "site/site.hpp"
#include "util/parallel_range.hpp"

namespace ssrfleet::fleet {
class ModelExtension;
}

namespace ssrfleet::model {

// A model extension (model_extension.hpp) held at fixed parameters ψ while a truck is fitted and
// tabulated: every pass of the search and of the table runs the extended forward model, so the
// table holds ℓ_i(θ, ψ) at that ψ. Extensions that edit the pass (a vehicle constant, the speed)
// and the output keep the line-bundled passes of the base table, at the same pass count; one that
// adds a profile costs one more pass per (k, k_t) node (and the search's passes twice), which
// TruckTable::passes does not count; one that moves the lateral position is refused (the lines
// are the lateral positions). With no extension (or one that edits nothing forward) the table is
// the base model's, bit for bit.
struct ForwardEdit {
  const fleet::ModelExtension* extension = nullptr;
  std::vector<double> psi;  // extension->dim() values inside its prior box
};

// The (k, k_t) nodes shared by every truck's table: node (i, j) sits at
// (k_origin + i dk, kt_origin + j dkt). The node sum is the rectangle rule on this infinite
// lattice, which for smooth integrands is spectrally accurate once the spacing is below about
// the integrand's width (trapezoid rule on R; error ~ exp(-2π² (width / spacing)²)).
struct Lattice {
  double k_origin_npm = 0.0;
  double dk_npm = 0.0;
  double kt_origin_npm = 0.0;
  double dkt_npm = 0.0;
  bool valid() const { return dk_npm > 0.0 && dkt_npm > 0.0; }
  double k_at(int i) const { return k_origin_npm + dk_npm * i; }
  double kt_at(int j) const { return kt_origin_npm + dkt_npm * j; }
};

struct TruckTableOptions {
  double sigma_ref = 0.02;     // σ_IF at which the table is expanded (u_ref = 1 / σ_ref²)
  double keep_nats = 12.0;     // node kept if log I_g(u_ref) >= best - keep_nats
  int points_per_segment = 10;    // Gauss–Legendre points per segment between two lines
  // Where the best-fit search starts (a hint: e.g. the fleet's current mean); the table does not
  // depend on it once the search finds the best fit.
  double k_start_npm = 447e3;
  double kt_start_npm = 1.58e6;
  // True: the coarse search scans the lines at the start point only (a start from the fleet's
  // posterior mean is good); false: at a 3 x 3 spread around it (the first trucks).
  bool start_is_close = false;
  // The fleet's stiffness distribution as the current posterior sees it (predictive mean and a
  // generous sd). When set, a node is kept by its share of likelihood x this density, not of the
  // likelihood alone: the likelihood's long flat tail towards stiff tyres, where no truck of the
  // fleet is, then costs nothing. Nodes dropped this way matter only if the fleet posterior later
  // moves several predictive sd, which FleetMarginal's rebuild rule watches.
  struct Population {
    double k_mean_npm = 0.0, k_sd_npm = 0.0, kt_mean_npm = 0.0, kt_sd_npm = 0.0;
  };
  std::optional<Population> population;
  // Lateral lines: every line of the road is scanned at the fit; each run of segments within
  // keep_nats of the best (a lateral mode) is tabulated on its own lines, widened by this many
  // lines each side (a node's z-optimum moves a few mm to cm with (k, k_t)).
  int z_margin_lines = 2;
  // A lateral run counts as a mode if its least SSR at the fit's (k, k_t) is within keep_nats plus
  // this of the best: the mode's own best (k, k_t) can lie a few nats higher than the fit's view of
  // it (road AS2: two modes missed at a margin of 0 carried 0.6 % of a truck's likelihood).
  double mode_margin_nats = 8.0;
  // A node whose z-likelihood is broader than this (its z-posterior sd at u_ref) is tabulated in
  // pieces of consecutive segments, each at most this broad, one entry per piece (the header,
  // "Pieces"). The lateral prior's moment matching errs by about (piece sd / σ_z)⁴ / 100 nats at
  // most, so a quarter of the fleet's σ_z is plenty; MarginalTarget sets it so.
  double max_piece_sd_m = 0.1;
  // The flood fill skips a neighbour of a kept node when the score's linear extrapolation through
  // the node and the one behind it falls this far below the threshold (a concave score lies below
  // it, so the neighbour would be evaluated only to be dropped). Negative: every neighbour is
  // evaluated, as before. Measured at 0.5 against -1 (Table 1 fleet on AS1, 600 trucks; the second
  // fleet on AS2, 120): 12 % and 11 % fewer table passes; 5 and 4 tables lost a node just above the
  // threshold, whose log-likelihood at the true θ moved by at most 1.1e-7 nats.
  double ring_margin_nats = 0.5;
  // If set, the table measures its own lateral approximation here (TruckTable::lateral_error_nats):
  // the fleet's current (Z, σ_z), e.g. the posterior means.
  struct LateralReference {
    double mean_m = 0.0, sd_m = 0.0;
  };
  std::optional<LateralReference> lateral_check;
  // The model the passes simulate: the base model unless an extension is set (ForwardEdit).
  ForwardEdit forward;
};

// The best fit of (k, k_t, z) to one truck's impact factors, and the curvature of its
// log-likelihood there (from the Gauss–Newton Hessian).
struct TruckFit {
  double stiffness_npm = 0.0;
  double tyre_stiffness_npm = 0.0;
  double lateral_m = 0.0;
  double ssr = 0.0;                 // sum of squared residuals at the fit
  double sigma_hat = 0.0;           // sqrt(ssr / (M - 3)): the truck's own noise estimate
  // Likelihood sd of k and k_t at σ_IF = sigma (z profiled out): sd = unit_sd * sigma.
  double stiffness_sd_per_sigma = 0.0;
  double tyre_stiffness_sd_per_sigma = 0.0;
  double stiffness_correlation = 0.0;  // corr(k, k_t) of the likelihood
  int passes = 0;                   // integrator passes spent on the search
  // The 4 bytes after `passes` that alignment would leave as padding, named so they are always 0:
  // a stream's truck log writes this struct's bytes whole (fleet/marginal_target_checkpoint.cpp),
  // and uninitialised padding made two runs' logs differ in those bytes and in their checksums.
  std::int32_t reserved = 0;
};

struct TruckTable {
  // Per node (structure of arrays, one entry per kept node).
  std::vector<std::int32_t> k_index, kt_index;  // lattice indices
  std::vector<float> c, m, b;       // log I_g(u) ≈ c - m u / 2 - b log u
  std::vector<float> z_mean_m;      // ẑ_g: the node's z-posterior mean at u_ref
  std::vector<float> z_var_m2;      // s²_g: the node's z-posterior variance at u_ref
  // Their slopes in u (the header): u_ref dẑ/du, and d(u s²)/du, both at u_ref. Zero for a quadratic
  // bowl, where ẑ is fixed and s² ∝ 1/u.
  std::vector<float> z_mean_slope_m;
  std::vector<float> z_var_slope_m2;
  double z_var_ref_m2 = 0.0;        // the truck's mean z-posterior variance at u_ref (a summary)
  double u_ref = 0.0;
  int sensors = 0;
  // Diagnostics.
  TruckFit fit;
  int nodes_evaluated = 0;          // before dropping
  int passes = 0;                   // integrator passes in all (search included)
  bool region_clipped = false;      // a node above the threshold sat on the searched region's edge
  int modes = 1;                    // lateral modes tabulated (runs of lines within the threshold)
  // With options.lateral_check: log of the truck's likelihood by the table's Gaussian z form minus
  // the same with the z-integral done exactly (the node's Gauss–Legendre points against the road's
  // N(z | Z, σ_z²)), at u_ref and that (Z, σ_z), over the kept nodes weighted by their share of
  // the likelihood times the fleet's predictive of (k, k_t). NaN without the check. Where the
  // sensors pin a truck's z down (road AS1: about 1e-4 nats) the moment matching is exact to the
  // budget; where they leave z broad and many-peaked across the lane (AS2) it is not.
  double lateral_error_nats = std::numeric_limits<double>::quiet_NaN();

  std::size_t nodes() const { return c.size(); }
  std::size_t bytes() const;        // memory held
};

// Finds the best fit (Gauss–Newton from a coarse search over z at a few (k, k_t)).
TruckFit fit_truck(const site::Site& site, double speed_mps, double sprung_mass_kg,
                   const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const TruckTableOptions& options);

// Builds the table of one truck on `lattice`. DataError-free: the record was checked on input;
// UsageError if the lattice is invalid or the impact factors do not match the site's sensors.
TruckTable build_truck_table(const site::Site& site, double speed_mps, double sprung_mass_kg,
                             const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const Lattice& lattice,
                             const TruckTableOptions& options);

// The same, with the fit already done (a rebuild on a new lattice reuses it).
TruckTable build_truck_table(const site::Site& site, double speed_mps, double sprung_mass_kg,
                             const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const Lattice& lattice,
                             const TruckTableOptions& options, const TruckFit& fit);

// The same with the integrator passes of each round split over `parallel` (same bits).
TruckTable build_truck_table(const site::Site& site, double speed_mps, double sprung_mass_kg,
                             const Eigen::Ref<const Eigen::VectorXd>& impact_factors, const Lattice& lattice,
                             const TruckTableOptions& options, const TruckFit& fit,
                             const util::ParallelRange& parallel);

// The brute-force reference the tables are tested against: log ∫ exp(-u SSR(k, kt, z) / 2)
// N(z | Z, σ_z²) dz over the whole road width at one (k, k_t), by adaptive composite
// Gauss–Legendre on every segment (z prior truncated to the road and normalised). With
// `z_moments`, also E[z] and E[z²] under the normalised integrand (the conditional of z at that
// (k, k_t)), for tests of drawn latents.
struct ZMoments {
  double mean = 0.0, second = 0.0;
};
double reference_log_z_integral(const site::Site& site, double speed_mps, double sprung_mass_kg,
                                const Eigen::Ref<const Eigen::VectorXd>& impact_factors, double stiffness_npm,
                                double tyre_stiffness_npm, double sigma_if, double lateral_mean_m,
                                double lateral_sd_m, ZMoments* z_moments = nullptr);

}  // namespace ssrfleet::model
