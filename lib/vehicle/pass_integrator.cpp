// The pass integrator (DESIGN.md §2): exact discretisation with the profile linear between
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
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "util/check.hpp"
#include "vehicle/discretisation.hpp"

namespace ssrfleet::vehicle {

namespace {

constexpr std::string_view kFn = "PassIntegrator";

// A position within this many samples of a grid point is on the grid (positions such as 76.0 m
// at 0.05 m give 1520.0000000000002 samples).
constexpr double kOnGridTolerance = 1e-9;

// Everything a truck needs per step, computed once per pass (once per MCMC proposal).
struct TruckCoefficients {
  std::array<double, 16> phi;  // row-major Phi
  std::array<double, 4> gamma;
  std::array<double, 4> q;
  double a = 0.0;    // k_t / W
  double b = 0.0;    // c_t / W
  double c_r = 0.0;  // a (1 - q0) - b q1: IF - 1 = c_r r + e (r - r_before) - a z0 - b z1
  double e = 0.0;    // b / h
  double step_s = 0.0;
};

// Rows y1, y1' of the state at an output a fraction f of a step beyond sample j:
// (y1, y1') = phi z_j + alpha r_j + beta r_{j+1}.
struct PartialCoefficients {
  std::array<double, 8> phi;  // rows 0 and 1 of Phi(f h), row-major
  std::array<double, 2> alpha;
  std::array<double, 2> beta;
};

TruckCoefficients truck_coefficients(const QuarterCar& car, double speed_mps, double dx_m,
                                     const std::vector<double>& fractions, PartialCoefficients* partial) {
  const StateSpace ss = state_space(car);
  const double h = dx_m / speed_mps;
  const Discretisation<2> d = discretise<2>(ss.A, ss.B, h);
  const Eigen::Vector4d p = d.Gamma0.col(0) - d.Gamma0.col(1) / h - d.Gamma1.col(0);
  const Eigen::Vector4d q = d.Gamma0.col(1) / h + d.Gamma1.col(0);
  const Eigen::Vector4d gamma = d.Phi * q + p;
  const double w = car.static_weight_n();
  TruckCoefficients c;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) c.phi[static_cast<std::size_t>(4 * i + j)] = d.Phi(i, j);
    c.gamma[static_cast<std::size_t>(i)] = gamma[i];
    c.q[static_cast<std::size_t>(i)] = q[i];
  }
  c.a = car.tyre_stiffness_npm / w;
  c.b = car.tyre_damping_nspm / w;
  c.c_r = c.a * (1.0 - q[0]) - c.b * q[1];
  c.e = c.b / h;
  c.step_s = h;
  for (std::size_t s = 0; s < fractions.size(); ++s) {
    const double f = fractions[s];
    const Discretisation<2> df = discretise<2>(ss.A, ss.B, f * h);
    const Eigen::Vector4d alpha = df.Phi * q + df.Gamma0.col(0) - df.Gamma0.col(1) / h - f * df.Gamma1.col(0);
    const Eigen::Vector4d beta = df.Gamma0.col(1) / h + f * df.Gamma1.col(0);
    PartialCoefficients& pc = partial[s];
    for (int i = 0; i < 2; ++i) {
      for (int j = 0; j < 4; ++j) pc.phi[static_cast<std::size_t>(4 * i + j)] = df.Phi(i, j);
      pc.alpha[static_cast<std::size_t>(i)] = alpha[i];
      pc.beta[static_cast<std::size_t>(i)] = beta[i];
    }
  }
  return c;
}

// The expressions below are shared by run() and run_batch() so that both give the same bits.
inline double affine4(double p0, double p1, double p2, double p3, double z0, double z1, double z2, double z3,
                      double g, double r) {
  return ((p0 * z0 + p1 * z1) + (p2 * z2 + p3 * z3)) + g * r;
}

inline double path_height(const double* la, const double* lb, double wa, double wb, Eigen::Index j) {
  return wa * la[j] + wb * lb[j];
}

// IF - 1 at a sample, from z there, the height there and the height one sample before.
template <bool Damped>
inline double grid_if_minus_one(double c_r, double e, double a, double b, double r, double r_before, double z0,
                                double z1) {
  if constexpr (Damped) {
    return ((c_r * r + e * (r - r_before)) - a * z0) - b * z1;
  } else {
    (void)e;
    (void)b;
    (void)r_before;
    (void)z1;
    return c_r * r - a * z0;
  }
}

// IF - 1 a fraction f of a step beyond sample j.
inline double partial_if_minus_one(const TruckCoefficients& c, const PartialCoefficients& pc, double f,
                                   const double* z, double r_j, double r_next) {
  const double y1 = affine4(pc.phi[0], pc.phi[1], pc.phi[2], pc.phi[3], z[0], z[1], z[2], z[3], pc.alpha[0], r_j) +
                    pc.beta[0] * r_next;
  const double y1d = affine4(pc.phi[4], pc.phi[5], pc.phi[6], pc.phi[7], z[0], z[1], z[2], z[3], pc.alpha[1], r_j) +
                     pc.beta[1] * r_next;
  const double dr = r_next - r_j;
  const double r = r_j + f * dr;
  const double slope = dr / c.step_s;
  return c.a * (r - y1) + c.b * (slope - y1d);
}

void initial_z(const TruckCoefficients& c, double r0, double* z) {
  // Static equilibrium on the first sample: x = (r0, 0, r0, 0), z = x - q r0.
  z[0] = r0 - c.q[0] * r0;
  z[1] = -(c.q[1] * r0);
  z[2] = r0 - c.q[2] * r0;
  z[3] = -(c.q[3] * r0);
}

void check_path(const WheelPath& path, const std::string& who) {
  if (path.line_a == nullptr || path.line_b == nullptr)
    throw std::invalid_argument(std::string(kFn) + ": " + who + "WheelPath has a null line (line_a or line_b)");
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

// Batched kernel state for one block of BS trucks, all in L1: coefficient and state arrays of
// BS doubles each (one per truck), and a chunk of wheel-path heights transposed to
// [sample][truck] so the inner loop over trucks reads contiguous memory.
constexpr int kChunk = 64;

template <int BS>
struct alignas(64) BlockState {
  double phi[16][BS];
  double gamma[4][BS];
  double a[BS], b[BS], c_r[BS], e[BS];
  double z[4][BS];
  double min_m[BS];
  double wa[BS], wb[BS];
  const double* la[BS];
  const double* lb[BS];
  double r[kChunk + 1][BS];
};

// Fills s.r rows 0..n with heights at samples k..k+n.
template <int BS>
void load_heights(BlockState<BS>& s, Eigen::Index k, int n) {
  for (int t = 0; t < BS; ++t) {
    const double* la = s.la[t];
    const double* lb = s.lb[t];
    const double wa = s.wa[t], wb = s.wb[t];
    for (int i = 0; i <= n; ++i) s.r[i][t] = path_height(la, lb, wa, wb, k + i);
  }
}

// n steps from the sample in row 0 of s.r; the inner loop over trucks vectorises.
template <int BS, bool Damped>
void advance(BlockState<BS>& s, int n) {
  for (int i = 0; i < n; ++i) {
    const double* __restrict r0 = s.r[i];
    const double* __restrict r1 = s.r[i + 1];
#pragma GCC ivdep
    for (int t = 0; t < BS; ++t) {
      const double z0 = s.z[0][t], z1 = s.z[1][t], z2 = s.z[2][t], z3 = s.z[3][t];
      const double rt = r0[t];
      const double n0 = affine4(s.phi[0][t], s.phi[1][t], s.phi[2][t], s.phi[3][t], z0, z1, z2, z3, s.gamma[0][t], rt);
      const double n1 = affine4(s.phi[4][t], s.phi[5][t], s.phi[6][t], s.phi[7][t], z0, z1, z2, z3, s.gamma[1][t], rt);
      const double n2 =
          affine4(s.phi[8][t], s.phi[9][t], s.phi[10][t], s.phi[11][t], z0, z1, z2, z3, s.gamma[2][t], rt);
      const double n3 =
          affine4(s.phi[12][t], s.phi[13][t], s.phi[14][t], s.phi[15][t], z0, z1, z2, z3, s.gamma[3][t], rt);
      s.z[0][t] = n0;
      s.z[1][t] = n1;
      s.z[2][t] = n2;
      s.z[3][t] = n3;
      const double m = grid_if_minus_one<Damped>(s.c_r[t], s.e[t], s.a[t], s.b[t], r1[t], rt, n0, n1);
      s.min_m[t] = m < s.min_m[t] ? m : s.min_m[t];
    }
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
                                " entries but there are " + std::to_string(positions_m_.size()) + " positions");

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
      const double n0 = affine4(c.phi[0], c.phi[1], c.phi[2], c.phi[3], z[0], z[1], z[2], z[3], c.gamma[0], r_k);
      const double n1 = affine4(c.phi[4], c.phi[5], c.phi[6], c.phi[7], z[0], z[1], z[2], z[3], c.gamma[1], r_k);
      const double n2 = affine4(c.phi[8], c.phi[9], c.phi[10], c.phi[11], z[0], z[1], z[2], z[3], c.gamma[2], r_k);
      const double n3 = affine4(c.phi[12], c.phi[13], c.phi[14], c.phi[15], z[0], z[1], z[2], z[3], c.gamma[3], r_k);
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
  if (static_cast<Eigen::Index>(paths.size()) != n) fail_size("paths", static_cast<Eigen::Index>(paths.size()));
  if (if_out.cols() != n) fail_size("if_out (columns)", if_out.cols());
  if (if_out.rows() != static_cast<Eigen::Index>(positions_m_.size()))
    throw std::invalid_argument(std::string(kFn) + "::run_batch(): if_out has " + std::to_string(if_out.rows()) +
                                " rows but there are " + std::to_string(positions_m_.size()) + " positions");
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::string who = truck_label(i);
    validate_truck(cars.car(i), who);
    check_positive(kFn, who + "speed_mps", speed_mps[i]);
    check_path(paths[static_cast<std::size_t>(i)], who);
  }
  if (min_if_out != nullptr) min_if_out->resize(n);
  if (n == 0) return;

  constexpr int BS = batch_block_trucks;
  const auto state = std::make_unique<BlockState<BS>>();
  BlockState<BS>& s = *state;
  const std::size_t nfrac = distinct_fractions_.size();
  std::vector<TruckCoefficients> coeffs(BS);
  std::vector<PartialCoefficients> partial(BS * std::max<std::size_t>(nfrac, 1));

  for (Eigen::Index b0 = 0; b0 < n; b0 += BS) {
    const int nb = static_cast<int>(std::min<Eigen::Index>(BS, n - b0));
    bool damped = false;
    for (int t = 0; t < BS; ++t) {
      // Lanes past the end of the batch repeat its last truck; their results are dropped.
      const Eigen::Index i = b0 + std::min(t, nb - 1);
      const std::size_t ut = static_cast<std::size_t>(t);
      if (t < nb) {
        coeffs[ut] = truck_coefficients(cars.car(i), speed_mps[i], dx_m_, distinct_fractions_,
                                        partial.data() + ut * nfrac);
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
          m = partial_if_minus_one(c, partial[static_cast<std::size_t>(t) * nfrac + static_cast<std::size_t>(slot)],
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
