// The fleet model's per-truck marginal likelihood (docs/inference.md):
//   ℓ_i(θ) = ∫∫∫ p(y_i | k, k_t, z, σ_IF) N(k | K, σ_k²) N(k_t | K_t, σ_kt²) N_road(z | Z, σ_z²) dk dk_t dz,
// the truck's latents integrated out, so the fleet posterior after n trucks is
// π_n(θ) ∝ p(θ) Π_i ℓ_i(θ) on the 7 hyperparameters alone. The z integral is done when the
// truck's table is built (truck_table.hpp); (k, k_t) by the rectangle rule on the shared lattice.
// With u = 1/σ_IF² and V_g = σ_z² + s²_g(u):
//   ℓ_i(θ) = (M/2) log(u / 2π) - log P_road(Z, σ_z) + log(Δk Δk_t) - log(2π σ_k σ_kt) - ½ log 2π
//            + log Σ_g exp( c_g - m_g u/2 - b_g log u - ½ a_g² - ½ β_g² - ½ log V_g - (ẑ_g(u) - Z)² / (2 V_g) ),
//   a_g = (k_g - K)/σ_k, β_g = (kt_g - K_t)/σ_kt.
// The entry's z-moments follow σ_IF to first order (truck_table.hpp), with x = u/u_ref - 1:
//   ẑ_g(u) = ẑ_g + x ẑ'_g,   s²_g(u) = (u_ref/u) max(s²_g + x v'_g, s²_g / 4).
// The max keeps s² positive where a large step meets a steep slope (then the correction is held at
// a quarter of the bowl's value); x is clamped to ±kMaxSlopeStep: a first-order expansion is
// trusted that far, and MarginalTarget rebuilds the tables long before the posterior's σ_IF moves so
// far from σ_ref (x ≈ ±0.1 at its tolerance). Far-off θ (the prior's, early in a fit) see moments
// held at the clamp's edge, not extrapolated out of the node's lateral window.
// a_g and β_g are linear in the node's lattice index, so the node sum reads only the table.
// Everything that depends on θ alone (not on the truck) is computed once per θ (ThetaTerms).
//
// Several sites, one fleet (docs/sites.md). A site enters ℓ_i only through its sensor count M
// and its lane [lo, hi] (P_road), both in the truck-independent part; everything else is in the
// truck's table, built through the truck's own site. So one FleetMarginal serves trucks of many
// sites: a constant per site (SiteConstants, ThetaTerms::site_constant), picked by the table's site.
// (A θ outside one site's support, P_road = 0, is outside the support of all.)
//
// The rectangle rule's error is about 2 exp(-2π² (w / Δ)²) for an integrand of width w on spacing
// Δ: negligible once w ≥ Δ, but a fleet sd far below Δ makes the node sum jump as K moves between
// nodes and overstate it by up to Δ / σ when K sits on a node. Summed over n trucks that is a spike
// a sampler falls into: evaluated as they are down to 0.3 spacings, the fleet sds of a 100-truck
// Table 1 fit on AS1 collapsed (σ_kt 5.4k ± 2.3k against the exact 210k), as the lattice, which
// follows the posterior, refined after them. So σ_k and σ_kt below kMinSdPerSpacing spacings are
// evaluated at that floor (the rule's error there, 2 exp(-2π² 0.8²) ≈ 6e-6 a truck), and
// MarginalTarget keeps the floor under the posterior instead: its spacing resolves the fleet sds'
// 0.1 % posterior quantile, so the floor sits at 0.8 of that quantile, where a floor at 0.8 of the
// 2 % quantile put a draw of σ_kt under it 2.4 nats off (road AS2, 1,000 trucks).
//
// Precision. The node sum runs in single precision, like the tables it reads: 1.7-2.4x faster
// than in double (side by side, 1,000 Table 1 trucks on AS1, 64 particles). Measured against the
// double sum there: at most 1.6e-6 nats per truck, and the total over 1,000 trucks varies by
// 2.5e-4 nats (sd) across particles: θ-dependent error, the part that could move a posterior,
// 2,000 times below the 0.5 nats that one posterior sd changes the log density by.
#pragma once

#include <algorithm>
#include <vector>

#include "model/fleet_model.hpp"
#include "model/model_extension.hpp"
#include "model/table_store.hpp"
#include "model/truck_table.hpp"
#include "util/exact_sum.hpp"

namespace ssrfleet::model {

// What makes one site's trucks' ℓ_i differ from another's, apart from their tables.
struct SiteConstants {
  int sensors = 0;
  fleet::LateralRange range;
};

// What ℓ_i(θ) needs of θ, computed once for all trucks.
struct ThetaTerms {
  double a0 = 0.0, da = 0.0;   // a_g = a0 + i da
  double b0 = 0.0, db = 0.0;   // β_g = b0 + j db
  double lateral_mean_m = 0.0;
  double lateral_var_m2 = 0.0;
  double u = 0.0, half_u = 0.0, log_u = 0.0;
  // The truck-independent part of ℓ_i for a truck of each site (M_s and P_road_s differ by site).
  std::vector<double> site_constant;
  bool inside = false;         // θ in the support (σ's positive, road mass positive)
  // A stiffness distribution other than the base model's N(K, σ_k²) (a model extension's mixture
  // of normals, ModelExtension::stiffness_mixture): node g takes log p(k_g) in place of
  // -½ a_g² - log σ_k - ½ log 2π, read from k_log_density[i - k_index_lo] (i the node's k index),
  // computed once per θ. Empty for the base model.
  struct KComponent {
    double log_weight = 0.0, mean_npm = 0.0, sd_npm = 0.0;  // sd already held to the floor
  };
  std::vector<KComponent> k_mixture;
  std::vector<float> k_log_density;
  int k_index_lo = 0;
  bool has_k_mixture() const { return !k_mixture.empty(); }
};

class FleetMarginal {
 public:
  static constexpr double kMinSdPerSpacing = 0.8;
  // The most components a stiffness mixture may have (prepare's std::invalid_argument beyond).
  static constexpr std::size_t kMaxStiffnessComponents = 8;
  // The moments' expansion (the header): x = u/u_ref - 1 clamped to ±kMaxSlopeStep; the variance's
  // correction never below kMinVarShare of its value at u_ref.
  static constexpr double kMaxSlopeStep = 0.25;
  static constexpr float kMinVarShare = 0.25f;
  static double slope_step(double u_ref, double u) {
    return u_ref > 0.0 ? std::clamp(u / u_ref - 1.0, -kMaxSlopeStep, kMaxSlopeStep) : 0.0;
  }
  // Entry g's z-likelihood moments at u, in double (the latent proposal's; the node sum's in float).
  struct EntryMoments {
    double z_mean_m = 0.0, z_var_m2 = 0.0;
  };
  static EntryMoments entry_moments(const TableView& table, std::size_t g, double u);

  FleetMarginal(int sensors, fleet::LateralRange range, Lattice lattice)
      : FleetMarginal(std::vector<SiteConstants>{{sensors, range}}, lattice) {}
  // Trucks of several sites (TableView::site indexes `sites`); at least one.
  FleetMarginal(std::vector<SiteConstants> sites, Lattice lattice);

  const Lattice& lattice() const { return lattice_; }
  const std::vector<SiteConstants>& sites() const { return sites_; }

  ThetaTerms prepare(const fleet::HyperVector& theta) const;
  // The same with the fleet's stiffness distribution a mixture of normals (weights summing to 1;
  // each component's sd is evaluated at the floor below if it lies under it, as σ_k is). The
  // node weights are tabulated for k indices [k_index_lo, k_index_hi] (the stored tables'
  // range: a node outside it is computed on the spot, with the same bits). One component of
  // weight 1 is the base model: prepare(theta), bit for bit.
  ThetaTerms prepare(const fleet::HyperVector& theta,
                     const std::vector<fleet::ModelExtension::StiffnessComponent>& stiffness, int k_index_lo,
                     int k_index_hi) const;
  // log p(k) at k index i under terms' mixture, in single precision (the node sum's).
  float k_log_density_at(const ThetaTerms& terms, int i) const;
  // ℓ_i(θ); -inf when θ is outside the support.
  double log_likelihood(const TableView& table, const ThetaTerms& terms) const;
  double log_likelihood(const TruckTable& table, const ThetaTerms& terms) const {
    return log_likelihood(view_of(table), terms);
  }
  // The node sum's terms before the exponential: ℓ_i(θ) = constant(θ) - ½ log σ_z² + log Σ_g exp(e_g),
  // e_g written to exponents[g] for each of table.nodes entries (the truck's latent posterior
  // given θ puts weight ∝ exp(e_g) on entry g: model/table_proposal.hpp).
  void entry_exponents(const TableView& table, const ThetaTerms& terms, float* exponents) const;
  // Σ_{i<end} ℓ_i(θ_p) for many particles at once: sums[p] for terms[p], p < count (-inf outside
  // the support). The trucks' ℓ_i are added exactly (util/exact_sum.hpp), so the bits do not depend
  // on the order of the trucks, on the blocks below, or on how the trucks are split between MPI
  // ranks (add_log_likelihoods, then Ranks::sum). The trucks are visited in blocks that stay in the
  // core's cache while every particle reads them, so a store larger than the cache (≈ 5 MB per
  // 1,000 trucks) is read from memory once per block of particles instead of once per particle
  // (kBlockEntries).
  void sum_log_likelihood(const TableStore& store, std::size_t end, const ThetaTerms* terms, std::size_t count,
                          double* sums) const;
  // The same, added to exact partial sums (sums[p] += Σ_{i<end} ℓ_i(θ_p)); one already settled
  // (a -inf term) is skipped.
  void add_log_likelihoods(const TableStore& store, std::size_t end, const ThetaTerms* terms, std::size_t count,
                           util::ExactSum* sums) const;
  // Table entries per block of trucks: 16,384 entries × 36 bytes ≈ 590 kB, within a 1 MB L2.
  static constexpr std::size_t kBlockEntries = 16384;

 private:
  std::vector<SiteConstants> sites_;
  Lattice lattice_;
};

}  // namespace ssrfleet::model
