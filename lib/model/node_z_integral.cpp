#include "model/node_z_integral.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ssrfleet::model::detail {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

std::vector<NodeResult> integrate_node(const Eigen::Ref<const Eigen::ArrayXXd>& ifs_by_line, Eigen::Index first_line,
                                       const road::Surface& surface, const Eigen::Ref<const Eigen::VectorXd>& y,
                                       double u_ref, const util::QuadratureRule& rule, double max_piece_sd,
                                       const std::optional<TruckTableOptions::LateralReference>& lateral) {
  const Eigen::Index lines = ifs_by_line.cols();
  const double dy = surface.dy_m;
  const std::size_t q = rule.nodes.size();
  std::vector<double> zs, ss, ws;
  zs.reserve(static_cast<std::size_t>(lines) * q);
  ss.reserve(zs.capacity());
  ws.reserve(zs.capacity());
  for (Eigen::Index j = 0; j + 1 < lines; ++j) {
    const Eigen::VectorXd ea = y - ifs_by_line.col(j).matrix();
    const Eigen::VectorXd d = (ifs_by_line.col(j + 1) - ifs_by_line.col(j)).matrix();
    const double aa = ea.squaredNorm(), ad = ea.dot(d), dd = d.squaredNorm();
    const double z0 = surface.lateral_m(first_line + j);
    for (std::size_t p = 0; p < q; ++p) {
      const double w = rule.nodes[p];
      zs.push_back(z0 + w * dy);
      ss.push_back(std::max(0.0, aa - 2.0 * w * ad + w * w * dd));
      ws.push_back(rule.weights[p] * dy);
    }
  }
  if (zs.empty()) return {};
  const double smin = *std::min_element(ss.begin(), ss.end());
  // From here on ws[i] is the point's share of the node's z-integral (the pieces and the lateral
  // check read it).
  for (std::size_t i = 0; i < zs.size(); ++i) ws[i] *= std::exp(-0.5 * u_ref * (ss[i] - smin));

  // One piece: the points [begin, end).
  auto piece = [&](std::size_t begin, std::size_t end) {
    NodeResult r;
    double sum = 0.0, s1 = 0.0, s2 = 0.0, z1 = 0.0, z2 = 0.0;
    for (std::size_t i = begin; i < end; ++i) {
      const double ds = ss[i] - smin;
      const double p = ws[i];
      sum += p;
      s1 += p * ds;
      s2 += p * ds * ds;
      z1 += p * zs[i];
      z2 += p * zs[i] * zs[i];
    }
    if (!(sum > 0.0)) return r;  // underflowed: carries nothing (log_i_ref = -inf drops it)
    const double mean_ds = s1 / sum;
    const double var_s = std::max(0.0, s2 / sum - mean_ds * mean_ds);
    r.log_i_ref = std::log(sum) - 0.5 * u_ref * smin;
    // Match value, slope and curvature of log I(u) at u_ref (see the header):
    // d/du log I = -E[SSR]/2, d²/du² log I = Var[SSR]/4.
    r.b = 0.25 * var_s * u_ref * u_ref;
    r.m = (smin + mean_ds) - 2.0 * r.b / u_ref;
    r.c = r.log_i_ref + 0.5 * r.m * u_ref + r.b * std::log(u_ref);
    r.z_mean = z1 / sum;
    r.z_var = std::max(0.0, z2 / sum - r.z_mean * r.z_mean);
    // u-derivatives (weights ∝ exp(-u SSR / 2)): dẑ/du = -Cov(z, SSR)/2, ds²/du = -Cov((z - ẑ)², SSR)/2,
    // by centred sums (the covariances are small differences of large moments).
    double cz = 0.0, cv = 0.0;
    for (std::size_t i = begin; i < end; ++i) {
      const double dz = zs[i] - r.z_mean, dsc = ss[i] - smin - mean_ds;
      cz += ws[i] * dz * dsc;
      cv += ws[i] * (dz * dz - r.z_var) * dsc;
    }
    r.z_mean_slope = -0.5 * u_ref * cz / sum;
    r.z_var_slope = r.z_var - 0.5 * u_ref * cv / sum;
    if (lateral) {
      double with_prior = 0.0;
      for (std::size_t i = begin; i < end; ++i)
        with_prior += ws[i] * std::exp(fleet::log_normal_density(zs[i], lateral->mean_m, lateral->sd_m));
      r.lateral_exact = std::log(with_prior / sum);
    }
    return r;
  };
  std::vector<NodeResult> pieces{piece(0, zs.size())};
  if (!(pieces[0].z_var > max_piece_sd * max_piece_sd)) return pieces;

  // Too broad for one Gaussian: cut between segments, greedily, closing a piece before the segment
  // that would lift its z-sd above max_piece_sd.
  pieces.clear();
  double p0 = 0.0, p1 = 0.0, p2 = 0.0;  // the open piece's Σp, Σpz, Σpz²
  std::size_t begin = 0;
  for (std::size_t seg = 0; seg * q < zs.size(); ++seg) {
    double a0 = 0.0, a1 = 0.0, a2 = 0.0;
    for (std::size_t i = seg * q; i < (seg + 1) * q; ++i) {
      a0 += ws[i];
      a1 += ws[i] * zs[i];
      a2 += ws[i] * zs[i] * zs[i];
    }
    const double n0 = p0 + a0, n1 = p1 + a1, n2 = p2 + a2;
    const double var = n0 > 0.0 ? n2 / n0 - (n1 / n0) * (n1 / n0) : 0.0;
    if (seg * q > begin && var > max_piece_sd * max_piece_sd) {
      pieces.push_back(piece(begin, seg * q));
      begin = seg * q;
      p0 = a0, p1 = a1, p2 = a2;
    } else {
      p0 = n0, p1 = n1, p2 = n2;
    }
  }
  pieces.push_back(piece(begin, zs.size()));
  return pieces;
}

}  // namespace ssrfleet::model::detail
