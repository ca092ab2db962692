#include "model/fleet_marginal.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <Eigen/Core>

namespace ssrfleet::model {

namespace {
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kLog2Pi = 1.8378770664093454836;
}  // namespace

FleetMarginal::FleetMarginal(int sensors, fleet::LateralRange range, Lattice lattice)
    : sensors_(sensors), range_(range), lattice_(lattice) {}

ThetaTerms FleetMarginal::prepare(const fleet::HyperVector& theta) const {
  using namespace fleet;
  ThetaTerms t;
  const double sk = theta[kSigmaK], skt = theta[kSigmaKt], sz = theta[kSigmaZ], sif = theta[kSigmaIf];
  if (!(sk > 0.0 && skt > 0.0 && sz > 0.0 && sif > 0.0)) return t;
  const double log_mass = log_normal_mass(range_.lo_m, range_.hi_m, theta[kZ], sz);
  if (!std::isfinite(log_mass)) return t;
  // The rectangle rule needs the population density to be smooth on the node spacing; a fleet sd
  // below kMinSdPerSpacing spacings is evaluated at that floor (see the header).
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
  t.constant = 0.5 * sensors_ * (t.log_u - kLog2Pi) - log_mass + std::log(lattice_.dk_npm * lattice_.dkt_npm) -
               (kLog2Pi + std::log(sk_q) + std::log(skt_q)) - 0.5 * kLog2Pi;
  t.inside = true;
  return t;
}

double FleetMarginal::log_likelihood(const TableView& table, const ThetaTerms& t) const {
  if (!t.inside) return kNegInf;
  const std::size_t n = table.nodes;
  // s²(u) = s²_ref u_ref / u: the z-posterior narrows as σ_IF does (exact for a quadratic bowl).
  // V_g = σ_z² (1 + ε_g), ε_g = s²_g u_ref / (u σ_z²) below 1e-2 in practice: expand log V_g and
  // 1 / V_g to second order in ε_g rather than pay a log and a division per node.
  const double eps_per_var = table.u_ref / (t.u * t.lateral_var_m2);
  const double inv_2var = 0.5 / t.lateral_var_m2;
  thread_local std::vector<double> exponents;
  exponents.resize(n);
  // Two passes, so the compiler vectorises the first (an element-wise map with no loop-carried
  // state; a running max in the same loop kept it scalar, 70 % of a fit's time) and Eigen the max
  // and the exponential sum. Same operations in the same order per node: the same bits.
  double* __restrict out = exponents.data();
  const std::int32_t* __restrict k_index = table.k_index;
  const std::int32_t* __restrict kt_index = table.kt_index;
  const float* __restrict c = table.c;
  const float* __restrict m = table.m;
  const float* __restrict bb = table.b;
  const float* __restrict z_mean = table.z_mean_m;
  const float* __restrict z_var = table.z_var_m2;
  const double a0 = t.a0, da = t.da, b0 = t.b0, db = t.db, half_u = t.half_u, log_u = t.log_u;
  const double lateral_mean = t.lateral_mean_m;
  for (std::size_t g = 0; g < n; ++g) {
    const double a = a0 + da * k_index[g];
    const double b = b0 + db * kt_index[g];
    const double dz = static_cast<double>(z_mean[g]) - lateral_mean;
    const double eps = static_cast<double>(z_var[g]) * eps_per_var;
    out[g] = static_cast<double>(c[g]) - static_cast<double>(m[g]) * half_u - static_cast<double>(bb[g]) * log_u -
             0.5 * (a * a + b * b) - 0.5 * eps - dz * dz * inv_2var * (1.0 - eps + eps * eps);
  }
  const Eigen::Map<const Eigen::ArrayXd> e(out, static_cast<Eigen::Index>(n));
  const double top = n > 0 ? e.maxCoeff() : kNegInf;
  if (!(top > kNegInf)) return kNegInf;
  const double sum = (e - top).exp().sum();
  return t.constant - 0.5 * std::log(t.lateral_var_m2) + top + std::log(sum);
}

}  // namespace ssrfleet::model
