// The pass integrator (docs/model.md): exact discretisation with the profile linear between
// samples, single truck and batched (structure of arrays, vectorised across trucks).
//
// Per step j -> j+1 the profile is r(x) = r_j + (r_{j+1} - r_j)(x - x_j)/dx, so the input
// u = (r, r') has r linear in time and r' = v (r_{j+1} - r_j)/dx = (r_{j+1} - r_j)/h constant,
// h = dx / v. With the FOH discretisation (discretisation.hpp) this gives exactly
//   x_{j+1} = Phi x_j + p r_j + q r_{j+1},
//   p = Gamma0_r - Gamma0_r'/h - Gamma1_r,   q = Gamma0_r'/h + Gamma1_r
// (column _r of Gamma multiplies r, column _r' multiplies r'). The change of variable
// z_j = x_j - q r_j turns this into the bare recurrence
//   z_{j+1} = Phi z_j + gamma r_j,   gamma = Phi q + p,
// which costs no more per step than a staircase; x is recovered as z + q r where IF is needed.
//
// IF at a sample j (for the outputs and for the pass minimum):
//   IF - 1 = (k_t (r_j - y1) + c_t (r'_j - y1')) / ((m1 + m2) g),
// where r'_j is the slope of the step just completed, (r_j - r_{j-1})/h, and r'_0 = 0 (the car
// starts at equilibrium as if the road were flat before x = 0). With c_t = 0 (the paper's model)
// the convention does not matter. At an output between samples j and j+1, r' is the slope of
// that step and the state comes from an exact partial step of fraction f from sample j.
#include "vehicle/pass_integrator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "util/check.hpp"
#include "vehicle/discretisation.hpp"
#include "vehicle/pass_kernel.hpp"

namespace ssrfleet::vehicle {

using namespace pass_kernel;

namespace {

constexpr std::string_view kFn = "PassIntegrator";

// A position within this many samples of a grid point is on the grid (positions such as 76.0 m
// at 0.05 m give 1520.0000000000002 samples).
constexpr double kOnGridTolerance = 1e-9;

void check_path(const WheelPath& path, const std::string& who) {
  if (path.line_a == nullptr || path.line_b == nullptr)
    throw std::invalid_argument(std::string(kFn) + ": " + who +
                                "WheelPath has a null line (line_a or line_b)");
  check_in_range(kFn, who + "WheelPath::weight_b", path.weight_b, 0.0, 1.0);
}

// Rethrows a check from validate(car) with the truck named.
void validate_truck(const QuarterCar& car, const std::string& who) {
  try {
    validate(car);
  } catch (const std::invalid_argument& err) {
    throw std::invalid_argument(std::string(kFn) + ": " + who + err.what());
  }
}

std::string truck_label(Eigen::Index i) { return "truck " + std::to_string(i) + ": "; }

}  // namespace

PassIntegrator::PassIntegrator(double dx_m, Eigen::Index samples, std::vector<double> positions_m)
    : dx_m_(dx_m), samples_(samples), positions_m_(std::move(positions_m)) {
  check_positive(kFn, "dx_m", dx_m_);
  check_greater_or_equal(kFn, "samples", samples_, Eigen::Index{2});
  const double length_m = dx_m_ * static_cast<double>(samples_ - 1);
  position_sample_.reserve(positions_m_.size());
  position_fraction_.reserve(positions_m_.size());
  for (std::size_t o = 0; o < positions_m_.size(); ++o) {
    const double p = positions_m_[o];
    const std::string name = "positions_m[" + std::to_string(o) + "]";
    check_finite(kFn, name, p);
    std::ostringstream msg;
    msg.precision(12);
    msg << kFn << ": " << name << ": sensor at " << p << " m ";
    if (p < 0.0) {
      msg << "is before the road's start at 0 m";
      throw std::invalid_argument(msg.str());
    }
    if (p > length_m + kOnGridTolerance * dx_m_) {
      msg << "is beyond the road's end at " << length_m << " m";
      throw std::invalid_argument(msg.str());
    }
    if (o > 0 && !(p > positions_m_[o - 1])) {
      msg << "does not follow the previous one at " << positions_m_[o - 1]
          << " m (positions must be strictly increasing)";
      throw std::invalid_argument(msg.str());
    }
    const double u = p / dx_m_;
    const double nearest = std::round(u);
    Eigen::Index j;
    double f;
    if (std::abs(u - nearest) <= kOnGridTolerance) {
      j = static_cast<Eigen::Index>(nearest);
      f = 0.0;
    } else {
      j = static_cast<Eigen::Index>(std::floor(u));
      f = u - static_cast<double>(j);
    }
    j = std::min(j, samples_ - 1);
    position_sample_.push_back(j);
    position_fraction_.push_back(f);
    if (f > 0.0) {
      auto it = std::find(distinct_fractions_.begin(), distinct_fractions_.end(), f);
      position_fraction_slot_.push_back(static_cast<int>(it - distinct_fractions_.begin()));
      if (it == distinct_fractions_.end()) distinct_fractions_.push_back(f);
    } else {
      position_fraction_slot_.push_back(-1);
    }
  }
}

PassExtremes PassIntegrator::run(const QuarterCar& car, double speed_mps, const WheelPath& path,
                                 Eigen::Ref<Eigen::VectorXd> if_out) const {
  validate_truck(car, "");
  check_positive(kFn, "speed_mps", speed_mps);
  check_path(path, "");
  if (if_out.size() != static_cast<Eigen::Index>(positions_m_.size()))
    throw std::invalid_argument(std::string(kFn) + "::run(): if_out has " + std::to_string(if_out.size()) +
                                " entries but there are " + std::to_string(positions_m_.size()) +
                                " positions");

  std::array<PartialCoefficients, 64> partial_small;
  std::vector<PartialCoefficients> partial_large;
  PartialCoefficients* partial = partial_small.data();
  if (distinct_fractions_.size() > partial_small.size()) {
    partial_large.resize(distinct_fractions_.size());
    partial = partial_large.data();
  }
  const TruckCoefficients c = truck_coefficients(car, speed_mps, dx_m_, distinct_fractions_, partial);
  const double* la = path.line_a;
  const double* lb = path.line_b;
  const double wb = path.weight_b;
  const double wa = 1.0 - wb;
  const bool damped = c.b > 0.0;

  double z[4];
  const double r0 = path_height(la, lb, wa, wb, 0);
  initial_z(c, r0, z);
  double min_m = grid_if_minus_one<true>(c.c_r, c.e, c.a, c.b, r0, r0, z[0], z[1]);

  Eigen::Index k = 0;
  double r_k = r0;
  for (std::size_t o = 0; o < positions_m_.size(); ++o) {
    const Eigen::Index target = position_sample_[o];
    for (; k < target; ++k) {
      const double r_next = path_height(la, lb, wa, wb, k + 1);
      const double n0 =
          affine4(c.phi[0], c.phi[1], c.phi[2], c.phi[3], z[0], z[1], z[2], z[3], c.gamma[0], r_k);
      const double n1 =
          affine4(c.phi[4], c.phi[5], c.phi[6], c.phi[7], z[0], z[1], z[2], z[3], c.gamma[1], r_k);
      const double n2 =
          affine4(c.phi[8], c.phi[9], c.phi[10], c.phi[11], z[0], z[1], z[2], z[3], c.gamma[2], r_k);
      const double n3 =
          affine4(c.phi[12], c.phi[13], c.phi[14], c.phi[15], z[0], z[1], z[2], z[3], c.gamma[3], r_k);
      z[0] = n0;
      z[1] = n1;
      z[2] = n2;
      z[3] = n3;
      const double m = damped ? grid_if_minus_one<true>(c.c_r, c.e, c.a, c.b, r_next, r_k, n0, n1)
                              : grid_if_minus_one<false>(c.c_r, c.e, c.a, c.b, r_next, r_k, n0, n1);
      min_m = m < min_m ? m : min_m;
      r_k = r_next;
    }
    double m;
    const int slot = position_fraction_slot_[o];
    if (slot < 0) {
      const double r_before = k > 0 ? path_height(la, lb, wa, wb, k - 1) : r_k;
      m = grid_if_minus_one<true>(c.c_r, c.e, c.a, c.b, r_k, r_before, z[0], z[1]);
    } else {
      const double r_next = path_height(la, lb, wa, wb, k + 1);
      m = partial_if_minus_one(c, partial[slot], position_fraction_[o], z, r_k, r_next);
      min_m = m < min_m ? m : min_m;
    }
    if_out[static_cast<Eigen::Index>(o)] = 1.0 + m;
  }
  return PassExtremes{1.0 + min_m};
}

void PassIntegrator::run_batch(const QuarterCarBatch& cars, const Eigen::ArrayXd& speed_mps,
                               const std::vector<WheelPath>& paths, Eigen::Ref<Eigen::ArrayXXd> if_out,
                               Eigen::ArrayXd* min_if_out) const {
  const Eigen::Index n = cars.size();
  const auto fail_size = [&](const std::string& what, Eigen::Index got) {
    throw std::invalid_argument(std::string(kFn) + "::run_batch(): " + what + " has " + std::to_string(got) +
                                " but the batch has " + std::to_string(n) + " trucks");
  };
  if (cars.unsprung_mass_kg.size() != n) fail_size("unsprung_mass_kg", cars.unsprung_mass_kg.size());
  if (cars.suspension_stiffness_npm.size() != n)
    fail_size("suspension_stiffness_npm", cars.suspension_stiffness_npm.size());
  if (cars.suspension_damping_nspm.size() != n)
    fail_size("suspension_damping_nspm", cars.suspension_damping_nspm.size());
  if (cars.tyre_stiffness_npm.size() != n) fail_size("tyre_stiffness_npm", cars.tyre_stiffness_npm.size());
  if (cars.tyre_damping_nspm.size() != n) fail_size("tyre_damping_nspm", cars.tyre_damping_nspm.size());
  if (speed_mps.size() != n) fail_size("speed_mps", speed_mps.size());
  if (static_cast<Eigen::Index>(paths.size()) != n)
    fail_size("paths", static_cast<Eigen::Index>(paths.size()));
  if (if_out.cols() != n) fail_size("if_out (columns)", if_out.cols());
  if (if_out.rows() != static_cast<Eigen::Index>(positions_m_.size()))
    throw std::invalid_argument(std::string(kFn) + "::run_batch(): if_out has " +
                                std::to_string(if_out.rows()) + " rows but there are " +
                                std::to_string(positions_m_.size()) + " positions");
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::string who = truck_label(i);
    validate_truck(cars.car(i), who);
    check_positive(kFn, who + "speed_mps", speed_mps[i]);
    check_path(paths[static_cast<std::size_t>(i)], who);
  }
  if (min_if_out != nullptr) min_if_out->resize(n);
  if (n == 0) return;

  // The narrowest block that holds a small batch (a Levenberg–Marquardt step asks for 1 to 4
  // passes): each lane computes the same expressions at any block width, so the bits do not
  // depend on it, and a 16-wide block would run 12 to 15 lanes for nothing.
  if (n <= 4)
    run_blocks<4>(cars, speed_mps, paths, if_out, min_if_out);
  else if (n <= 8)
    run_blocks<8>(cars, speed_mps, paths, if_out, min_if_out);
  else
    run_blocks<batch_block_trucks>(cars, speed_mps, paths, if_out, min_if_out);
}

template <int BS>
void PassIntegrator::run_blocks(const QuarterCarBatch& cars, const Eigen::ArrayXd& speed_mps,
                                const std::vector<WheelPath>& paths, Eigen::Ref<Eigen::ArrayXXd> if_out,
                                Eigen::ArrayXd* min_if_out) const {
  const Eigen::Index n = cars.size();
  const auto state = std::make_unique<BlockState<BS>>();
  BlockState<BS>& s = *state;
  const std::size_t nfrac = distinct_fractions_.size();
  std::vector<TruckCoefficients> coeffs(BS);
  std::vector<PartialCoefficients> partial(BS * std::max<std::size_t>(nfrac, 1));
  // The discretisation of the last car seen: a batch often runs one car on many wheel paths (a
  // truck table's node on each lateral line), and the matrix exponentials are then done once.
  QuarterCar last_car;
  double last_speed = -1.0;
  TruckCoefficients last_coeffs;
  std::vector<PartialCoefficients> last_partial(std::max<std::size_t>(nfrac, 1));
  auto same_car = [&](const QuarterCar& a, double speed) { return speed == last_speed && a == last_car; };

  for (Eigen::Index b0 = 0; b0 < n; b0 += BS) {
    const int nb = static_cast<int>(std::min<Eigen::Index>(BS, n - b0));
    bool damped = false;
    for (int t = 0; t < BS; ++t) {
      // Lanes past the end of the batch repeat its last truck; their results are dropped.
      const Eigen::Index i = b0 + std::min(t, nb - 1);
      const std::size_t ut = static_cast<std::size_t>(t);
      if (t < nb) {
        const QuarterCar car = cars.car(i);
        if (!same_car(car, speed_mps[i])) {
          last_coeffs = truck_coefficients(car, speed_mps[i], dx_m_, distinct_fractions_, last_partial.data());
          last_car = car;
          last_speed = speed_mps[i];
        }
        coeffs[ut] = last_coeffs;
        std::copy(last_partial.begin(), last_partial.begin() + static_cast<std::ptrdiff_t>(nfrac),
                  partial.begin() + static_cast<std::ptrdiff_t>(ut * nfrac));
      } else {
        coeffs[ut] = coeffs[static_cast<std::size_t>(nb - 1)];
      }
      const TruckCoefficients& c = coeffs[ut];
      for (int r = 0; r < 16; ++r) s.phi[r][t] = c.phi[static_cast<std::size_t>(r)];
      for (int r = 0; r < 4; ++r) s.gamma[r][t] = c.gamma[static_cast<std::size_t>(r)];
      s.a[t] = c.a;
      s.b[t] = c.b;
      s.c_r[t] = c.c_r;
      s.e[t] = c.e;
      damped = damped || c.b > 0.0;
      const WheelPath& path = paths[static_cast<std::size_t>(i)];
      s.la[t] = path.line_a;
      s.lb[t] = path.line_b;
      s.wb[t] = path.weight_b;
      s.wa[t] = 1.0 - path.weight_b;
      const double r0 = path_height(s.la[t], s.lb[t], s.wa[t], s.wb[t], 0);
      double z[4];
      initial_z(c, r0, z);
      for (int r = 0; r < 4; ++r) s.z[r][t] = z[r];
      s.min_m[t] = grid_if_minus_one<true>(c.c_r, c.e, c.a, c.b, r0, r0, z[0], z[1]);
    }

    Eigen::Index k = 0;
    for (std::size_t o = 0; o < positions_m_.size(); ++o) {
      const Eigen::Index target = position_sample_[o];
      while (k < target) {
        const int steps = static_cast<int>(std::min<Eigen::Index>(kChunk, target - k));
        load_heights(s, k, steps);
        if (damped)
          advance<BS, true>(s, steps);
        else
          advance<BS, false>(s, steps);
        k += steps;
      }
      const int slot = position_fraction_slot_[o];
      for (int t = 0; t < nb; ++t) {
        const TruckCoefficients& c = coeffs[static_cast<std::size_t>(t)];
        const double r_k = path_height(s.la[t], s.lb[t], s.wa[t], s.wb[t], k);
        const double z[4] = {s.z[0][t], s.z[1][t], s.z[2][t], s.z[3][t]};
        double m;
        if (slot < 0) {
          const double r_before = k > 0 ? path_height(s.la[t], s.lb[t], s.wa[t], s.wb[t], k - 1) : r_k;
          m = grid_if_minus_one<true>(c.c_r, c.e, c.a, c.b, r_k, r_before, z[0], z[1]);
        } else {
          const double r_next = path_height(s.la[t], s.lb[t], s.wa[t], s.wb[t], k + 1);
          m = partial_if_minus_one(
              c, partial[static_cast<std::size_t>(t) * nfrac + static_cast<std::size_t>(slot)],
              position_fraction_[o], z, r_k, r_next);
          s.min_m[t] = m < s.min_m[t] ? m : s.min_m[t];
        }
        if_out(static_cast<Eigen::Index>(o), b0 + t) = 1.0 + m;
      }
    }
    if (min_if_out != nullptr)
      for (int t = 0; t < nb; ++t) (*min_if_out)[b0 + t] = 1.0 + s.min_m[t];
  }
}

}  // namespace ssrfleet::vehicle
