#include "model/fleet_marginal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <Eigen/Core>

namespace ssrfleet::model {

namespace {
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kLog2Pi = 1.8378770664093454836;
}  // namespace

FleetMarginal::FleetMarginal(std::vector<SiteConstants> sites, Lattice lattice)
    : sites_(std::move(sites)), lattice_(lattice) {
  if (sites_.empty()) throw std::invalid_argument("FleetMarginal: no site");
}

ThetaTerms FleetMarginal::prepare(const fleet::HyperVector& theta) const {
  using namespace fleet;
  ThetaTerms t;
  const double sk = theta[kSigmaK], skt = theta[kSigmaKt], sz = theta[kSigmaZ], sif = theta[kSigmaIf];
  if (!(sk > 0.0 && skt > 0.0 && sz > 0.0 && sif > 0.0)) return t;
  // site_constant holds each site's log P_road until the constants replace it below.
  std::vector<double>& log_mass = t.site_constant;
  log_mass.resize(sites_.size());
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    log_mass[s] = log_normal_mass(sites_[s].range.lo_m, sites_[s].range.hi_m, theta[kZ], sz);
    if (!std::isfinite(log_mass[s])) return t;
  }
  // The rectangle rule needs the population density to be smooth on the node spacing; a fleet sd
  // below kMinSdPerSpacing spacings is evaluated at that floor, which the lattice keeps under the
  // posterior (see the header).
  const double sk_q = std::max(sk, kMinSdPerSpacing * lattice_.dk_npm);
  const double skt_q = std::max(skt, kMinSdPerSpacing * lattice_.dkt_npm);
  t.a0 = (lattice_.k_origin_npm - theta[kK]) / sk_q;
  t.da = lattice_.dk_npm / sk_q;
  t.b0 = (lattice_.kt_origin_npm - theta[kKt]) / skt_q;
  t.db = lattice_.dkt_npm / skt_q;
  t.lateral_mean_m = theta[kZ];
  t.lateral_var_m2 = sz * sz;
  t.u = 1.0 / (sif * sif);
  t.half_u = 0.5 * t.u;
  t.log_u = std::log(t.u);
  // Each site's whole constant, summed in one order for every site (that of the one-site code
  // before sites existed, so a fit of one site keeps its bits).
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    t.site_constant[s] = 0.5 * sites_[s].sensors * (t.log_u - kLog2Pi) - log_mass[s] +
                         std::log(lattice_.dk_npm * lattice_.dkt_npm) - (kLog2Pi + std::log(sk_q) + std::log(skt_q)) -
                         0.5 * kLog2Pi;
  }
  t.inside = true;
  return t;
}

ThetaTerms FleetMarginal::prepare(const fleet::HyperVector& theta,
                                  const std::vector<fleet::ModelExtension::StiffnessComponent>& stiffness,
                                  int k_index_lo, int k_index_hi) const {
  ThetaTerms t = prepare(theta);
  if (!t.inside) return t;
  if (stiffness.size() == 1 && stiffness[0].weight == 1.0 && stiffness[0].mean_npm == theta[fleet::kK] &&
      stiffness[0].sd_npm == theta[fleet::kSigmaK]) {
    return t;
  }
  if (stiffness.size() > kMaxStiffnessComponents) throw std::invalid_argument("FleetMarginal: too many stiffness components");
  const double floor_sd = kMinSdPerSpacing * lattice_.dk_npm;
  for (const auto& c : stiffness) {
    if (!(c.weight > 0.0)) continue;
    if (!(c.sd_npm > 0.0)) {
      t.inside = false;
      return t;
    }
    t.k_mixture.push_back({std::log(c.weight), c.mean_npm, std::max(c.sd_npm, floor_sd)});
  }
  if (t.k_mixture.empty()) {
    t.inside = false;
    return t;
  }
  // The constant held the base model's -½ log 2π - log σ_k; the mixture's density replaces it.
  const double sk_q = std::max(theta[fleet::kSigmaK], floor_sd);
  for (double& c : t.site_constant) c += 0.5 * kLog2Pi + std::log(sk_q);
  t.k_index_lo = k_index_lo;
  if (k_index_hi >= k_index_lo) {
    t.k_log_density.resize(static_cast<std::size_t>(k_index_hi - k_index_lo + 1));
    for (int i = k_index_lo; i <= k_index_hi; ++i)
      t.k_log_density[static_cast<std::size_t>(i - k_index_lo)] = k_log_density_at(t, i);
  }
  return t;
}

float FleetMarginal::k_log_density_at(const ThetaTerms& t, int i) const {
  const double k = lattice_.k_at(i);
  double top = -std::numeric_limits<double>::infinity();
  double terms[kMaxStiffnessComponents];
  const std::size_t n = t.k_mixture.size();
  for (std::size_t c = 0; c < n; ++c) {
    const auto& m = t.k_mixture[c];
    const double a = (k - m.mean_npm) / m.sd_npm;
    terms[c] = m.log_weight - 0.5 * a * a - std::log(m.sd_npm) - 0.5 * kLog2Pi;
    top = std::max(top, terms[c]);
  }
  double sum = 0.0;
  for (std::size_t c = 0; c < n; ++c) sum += std::exp(terms[c] - top);
  return static_cast<float>(top + std::log(sum));
}

void FleetMarginal::entry_exponents(const TableView& table, const ThetaTerms& t, float* exponents) const {
  const std::size_t n = table.nodes;
  const float eps_per_var = static_cast<float>(table.u_ref / (t.u * t.lateral_var_m2));
  const float inv_2var = static_cast<float>(0.5 / t.lateral_var_m2);
  const float x = static_cast<float>(slope_step(table.u_ref, t.u));
  float* __restrict out = exponents;
  const std::int32_t* __restrict k_index = table.k_index;
  const std::int32_t* __restrict kt_index = table.kt_index;
  const float* __restrict c = table.c;
  const float* __restrict m = table.m;
  const float* __restrict bb = table.b;
  const float* __restrict z_mean = table.z_mean_m;
  const float* __restrict z_var = table.z_var_m2;
  // A table without slopes (built in memory without them) is read as slopes of 0: x times any
  // finite number is 0, so its own moments serve as the stand-in array.
  const float* __restrict z_mean_slope = table.z_mean_slope_m != nullptr ? table.z_mean_slope_m : table.z_mean_m;
  const float* __restrict z_var_slope = table.z_var_slope_m2 != nullptr ? table.z_var_slope_m2 : table.z_var_m2;
  const float x_used = table.z_mean_slope_m != nullptr && table.z_var_slope_m2 != nullptr ? x : 0.0f;
  const float a0 = static_cast<float>(t.a0), da = static_cast<float>(t.da), b0 = static_cast<float>(t.b0),
              db = static_cast<float>(t.db), half_u = static_cast<float>(t.half_u), log_u = static_cast<float>(t.log_u);
  const float lateral_mean = static_cast<float>(t.lateral_mean_m);
  // One loop for both fleets: `fleet_term(g, b)` is -log of the node's (k, k_t) weight up to the
  // constant, ½(a² + β²) for the base model; a generic lambda, so the base loop stays the
  // element-wise map the compiler vectorises.
  auto fill = [&](auto fleet_term) {
    for (std::size_t g = 0; g < n; ++g) {
      const float b = b0 + db * static_cast<float>(kt_index[g]);
      const float dz = z_mean[g] + x_used * z_mean_slope[g] - lateral_mean;
      const float var = std::max(z_var[g] + x_used * z_var_slope[g], kMinVarShare * z_var[g]);
      const float eps = var * eps_per_var;
      out[g] = c[g] - m[g] * half_u - bb[g] * log_u - fleet_term(g, b) - 0.5f * eps -
               dz * dz * inv_2var * (1.0f - eps + eps * eps);
    }
  };
  if (t.has_k_mixture()) {
    // The node's k weight from the mixture's table (computed on the spot outside its range).
    const float* density = t.k_log_density.data();
    const auto size = static_cast<std::int64_t>(t.k_log_density.size());
    fill([&](std::size_t g, float b) {
      const std::int64_t at = static_cast<std::int64_t>(k_index[g]) - t.k_index_lo;
      const float kd = at >= 0 && at < size ? density[at] : k_log_density_at(t, k_index[g]);
      return 0.5f * b * b - kd;
    });
  } else {
    fill([&](std::size_t g, float b) {
      const float a = a0 + da * static_cast<float>(k_index[g]);
      return 0.5f * (a * a + b * b);
    });
  }
}

FleetMarginal::EntryMoments FleetMarginal::entry_moments(const TableView& table, std::size_t g, double u) {
  const double z_var = table.z_var_m2[g];
  EntryMoments e{table.z_mean_m[g], z_var};
  if (table.z_mean_slope_m != nullptr && table.z_var_slope_m2 != nullptr) {
    const double x = slope_step(table.u_ref, u);
    e.z_mean_m += x * table.z_mean_slope_m[g];
    e.z_var_m2 = std::max(z_var + x * table.z_var_slope_m2[g], static_cast<double>(kMinVarShare) * z_var);
  }
  e.z_var_m2 *= table.u_ref / u;
  return e;
}

double FleetMarginal::log_likelihood(const TableView& table, const ThetaTerms& t) const {
  if (!t.inside) return kNegInf;
  const std::size_t n = table.nodes;
  // ẑ_g(u) and s²_g(u) to first order in u from u_ref (the header). V_g = σ_z² (1 + ε_g),
  // ε_g = s²_g(u) / σ_z² below 1e-2 in practice: expand log V_g and 1 / V_g to second order in ε_g
  // rather than pay a log and a division per node.
  //
  // The map runs in single precision (the header, "Precision"): the table is float already, and
  // float doubles the SIMD width of the map and of the exponential, where a fit spends most of
  // its time. Two passes, so the compiler vectorises the first (an element-wise map with no
  // loop-carried state; a running max in the same loop kept it scalar) and Eigen the max and the
  // exponential sum.
  thread_local std::vector<float> exponents;
  exponents.resize(n);
  const float* out = exponents.data();
  entry_exponents(table, t, exponents.data());
  const Eigen::Map<const Eigen::ArrayXf> e(out, static_cast<Eigen::Index>(n));
  const float top = n > 0 ? e.maxCoeff() : -std::numeric_limits<float>::infinity();
  if (!(top > -std::numeric_limits<float>::infinity())) return kNegInf;
  const double sum = static_cast<double>((e - top).exp().sum());
  return t.site_constant[table.site] - 0.5 * std::log(t.lateral_var_m2) + static_cast<double>(top) + std::log(sum);
}

void FleetMarginal::sum_log_likelihood(const TableStore& store, std::size_t end, const ThetaTerms* terms,
                                       std::size_t count, double* sums) const {
  std::vector<util::ExactSum> exact(count);
  add_log_likelihoods(store, end, terms, count, exact.data());
  for (std::size_t p = 0; p < count; ++p) sums[p] = exact[p].value();
}

void FleetMarginal::add_log_likelihoods(const TableStore& store, std::size_t end, const ThetaTerms* terms,
                                        std::size_t count, util::ExactSum* sums) const {
  for (std::size_t p = 0; p < count; ++p)
    if (!terms[p].inside) sums[p].add(kNegInf);
  const auto offset = [&store](std::size_t i) { return store.node_offset(i); };
  std::size_t first = 0;
  while (first < end) {
    // The block: trucks [first, last) holding about kBlockEntries entries (at least one truck).
    std::size_t last = first + 1;
    while (last < end && offset(last) - offset(first) < kBlockEntries) ++last;
    for (std::size_t p = 0; p < count; ++p) {
      util::ExactSum& s = sums[p];
      for (std::size_t i = first; i < last && !s.settled(); ++i) s.add(log_likelihood(store.view(i), terms[p]));
    }
    first = last;
  }
}

}  // namespace ssrfleet::model
