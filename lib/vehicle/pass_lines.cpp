// PassIntegrator::run_on_lines: many cars, each over every line of a LineBundle. A block's lanes
// are lines and it runs a few cars on them at once, so a car's coefficients are the same in every
// lane (held once, not once per lane as in run_batch's blocks) and the heights, already
// transposed by the bundle, are read once for all the block's cars. Per lane it computes
// run_batch's expressions (pass_kernel.hpp), with no pass minimum (the callers, truck tables, do
// not ask for it).
#include <algorithm>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "util/check.hpp"
#include "vehicle/pass_integrator.hpp"
#include "vehicle/pass_kernel.hpp"

namespace ssrfleet::vehicle {

using namespace pass_kernel;

namespace {

constexpr int kMaxLanes = 32;

// Steps from sample `from` to sample `to` of C cars, each on the LW lanes from lane0. The cars
// share the heights of a step, and C x LW near 32 keeps enough independent work in flight: one
// car on 8 lanes waits on its own recurrence (measured 0.84 ns per lane-step, against 0.34 for
// two cars on 8 lanes and 0.30 for four; 0.31 for two cars on 16, 0.37 for one car on 32).
template <int LW, int C>
inline void advance_lanes(const TruckCoefficients* const (&c)[C], double (&z)[C][4][LW], const LineBundle& bundle,
                          int lane0, Eigen::Index from, Eigen::Index to) {
  for (Eigen::Index j = from; j < to; ++j) {
    const double* __restrict r = bundle.row(j) + lane0;
#pragma GCC ivdep
    for (int t = 0; t < LW; ++t) {
      const double rt = r[t];
#pragma GCC unroll 4
      for (int k = 0; k < C; ++k) {
        const auto& p = c[k]->phi;
        const auto& g = c[k]->gamma;
        const double z0 = z[k][0][t], z1 = z[k][1][t], z2 = z[k][2][t], z3 = z[k][3][t];
        z[k][0][t] = affine4(p[0], p[1], p[2], p[3], z0, z1, z2, z3, g[0], rt);
        z[k][1][t] = affine4(p[4], p[5], p[6], p[7], z0, z1, z2, z3, g[1], rt);
        z[k][2][t] = affine4(p[8], p[9], p[10], p[11], z0, z1, z2, z3, g[2], rt);
        z[k][3][t] = affine4(p[12], p[13], p[14], p[15], z0, z1, z2, z3, g[3], rt);
      }
    }
  }
}

}  // namespace

template <int LW, int C>
void PassIntegrator::run_lane_block(const TruckCoefficients* coefficients, const PartialCoefficients* partial,
                                    Eigen::Index first_car, int cars, const LineBundle& bundle, int lane0, int lanes,
                                    Eigen::Ref<Eigen::ArrayXXd> if_out) const {
  const std::size_t nfrac = std::max<std::size_t>(distinct_fractions_.size(), 1);
  // Slots past the last car repeat it; their results are dropped.
  const TruckCoefficients* c[C];
  for (int k = 0; k < C; ++k) c[k] = coefficients + first_car + std::min(k, cars - 1);
  alignas(64) double z[C][4][LW];
  for (int k = 0; k < C; ++k) {
    for (int t = 0; t < LW; ++t) {
      double z0[4];
      initial_z(*c[k], bundle.row(0)[lane0 + t], z0);
      for (int i = 0; i < 4; ++i) z[k][i][t] = z0[i];
    }
  }
  const int lines = bundle.lines();
  Eigen::Index j = 0;
  for (std::size_t o = 0; o < positions_m_.size(); ++o) {
    const Eigen::Index target = position_sample_[o];
    advance_lanes<LW, C>(c, z, bundle, lane0, j, target);
    j = std::max(j, target);
    const int slot = position_fraction_slot_[o];
    const double* row = bundle.row(j) + lane0;
    for (int k = 0; k < cars; ++k) {
      const TruckCoefficients& ck = *c[k];
      const Eigen::Index col0 = (first_car + k) * lines + lane0;
      for (int t = 0; t < lanes; ++t) {
        const double zt[4] = {z[k][0][t], z[k][1][t], z[k][2][t], z[k][3][t]};
        double m;
        if (slot < 0) {
          const double r_before = j > 0 ? bundle.row(j - 1)[lane0 + t] : row[t];
          m = grid_if_minus_one<true>(ck.c_r, ck.e, ck.a, ck.b, row[t], r_before, zt[0], zt[1]);
        } else {
          const PartialCoefficients& pc = partial[static_cast<std::size_t>(first_car + k) * nfrac + static_cast<std::size_t>(slot)];
          m = partial_if_minus_one(ck, pc, position_fraction_[o], zt, row[t], bundle.row(j + 1)[lane0 + t]);
        }
        if_out(static_cast<Eigen::Index>(o), col0 + t) = 1.0 + m;
      }
    }
  }
}

void PassIntegrator::run_on_lines(const QuarterCarBatch& cars, double speed_mps, const LineBundle& bundle,
                                  Eigen::Ref<Eigen::ArrayXXd> if_out) const {
  const std::string fn = "PassIntegrator::run_on_lines()";
  const Eigen::Index n = cars.size();
  const int lines = bundle.lines();
  check_positive(fn, "speed_mps", speed_mps);
  if (bundle.samples() != samples_)
    throw std::invalid_argument(fn + ": the bundle has " + std::to_string(bundle.samples()) + " samples per line, the road " +
                                std::to_string(samples_));
  if (if_out.rows() != static_cast<Eigen::Index>(positions_m_.size()) || if_out.cols() != n * lines)
    throw std::invalid_argument(fn + ": if_out is " + std::to_string(if_out.rows()) + " x " + std::to_string(if_out.cols()) +
                                ", expected " + std::to_string(positions_m_.size()) + " x " + std::to_string(n * lines) +
                                " (positions x cars x lines)");
  for (Eigen::Index i = 0; i < n; ++i) {
    try {
      validate(cars.car(i));
    } catch (const std::invalid_argument& err) {
      throw std::invalid_argument(fn + ": car " + std::to_string(i) + ": " + err.what());
    }
  }
  if (n == 0) return;
  // Every car's discretisation once, for all its lanes.
  const std::size_t nfrac = std::max<std::size_t>(distinct_fractions_.size(), 1);
  std::vector<TruckCoefficients> coefficients(static_cast<std::size_t>(n));
  std::vector<PartialCoefficients> partial(static_cast<std::size_t>(n) * nfrac);
  for (Eigen::Index i = 0; i < n; ++i) {
    coefficients[static_cast<std::size_t>(i)] = truck_coefficients(cars.car(i), speed_mps, dx_m_, distinct_fractions_,
                                                                   partial.data() + static_cast<std::size_t>(i) * nfrac);
  }
  // The lines in chunks of at most 32 lanes; per chunk, the cars in groups that fill about 32.
  for (int lane0 = 0; lane0 < lines; lane0 += kMaxLanes) {
    const int count = std::min(kMaxLanes, lines - lane0);
    const auto run_groups = [&](auto width, auto group) {
      constexpr int LW = decltype(width)::value, C = decltype(group)::value;
      for (Eigen::Index first = 0; first < n; first += C) {
        const int here = static_cast<int>(std::min<Eigen::Index>(C, n - first));
        run_lane_block<LW, C>(coefficients.data(), partial.data(), first, here, bundle, lane0, count, if_out);
      }
    };
    // Lanes in fours (the bundle's padding), and as many cars as bring the block to about 32.
    switch ((count + 3) / 4) {
      case 1: run_groups(std::integral_constant<int, 4>{}, std::integral_constant<int, 8>{}); break;
      case 2: run_groups(std::integral_constant<int, 8>{}, std::integral_constant<int, 4>{}); break;
      case 3: run_groups(std::integral_constant<int, 12>{}, std::integral_constant<int, 3>{}); break;
      case 4: run_groups(std::integral_constant<int, 16>{}, std::integral_constant<int, 2>{}); break;
      case 5: run_groups(std::integral_constant<int, 20>{}, std::integral_constant<int, 2>{}); break;
      case 6: run_groups(std::integral_constant<int, 24>{}, std::integral_constant<int, 1>{}); break;
      case 7: run_groups(std::integral_constant<int, 28>{}, std::integral_constant<int, 1>{}); break;
      default: run_groups(std::integral_constant<int, 32>{}, std::integral_constant<int, 1>{}); break;
    }
  }
}

}  // namespace ssrfleet::vehicle
