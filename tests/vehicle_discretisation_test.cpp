// The exact discretisation (vehicle/discretisation.hpp) against a published known answer (the IRI
// Golden Car's ST and PR matrices: Sayers, M.W. (1995) "On the calculation of International
// Roughness Index from longitudinal road profile", Transportation Research Record 1501; ASTM E1926)
// and against the augmented matrix exponential.
#include <catch2/catch.hpp>

#include <cmath>
#include <complex>

#include "vehicle/discretisation.hpp"
#include "vehicle/frequency_response.hpp"
#include "vehicle/quarter_car.hpp"

using namespace ssrfleet::vehicle;

namespace {

// An independent reference in extended precision: the augmented exponential
// exp([[A h, B h, 0], [0, 0, I], [0, 0, 0]]) by scaling and squaring a degree-30 Taylor series in
// long double (64-bit mantissa), so its own error (~1e-18) is far below what is tested.
template <int Inputs>
Discretisation<Inputs> long_double_reference(const Eigen::Matrix4d& A,
                                             const Eigen::Matrix<double, 4, Inputs>& B, double h) {
  constexpr int N = 4 + 2 * Inputs;
  using ML = Eigen::Matrix<long double, N, N>;
  ML M = ML::Zero();
  M.template topLeftCorner<4, 4>() = A.cast<long double>() * static_cast<long double>(h);
  M.template block<4, Inputs>(0, 4) = B.template cast<long double>() * static_cast<long double>(h);
  M.template block<Inputs, Inputs>(4, 4 + Inputs).setIdentity();
  int squarings = 0;
  while (M.cwiseAbs().colwise().sum().maxCoeff() > 0.25L) {
    M /= 2.0L;
    ++squarings;
  }
  ML E = ML::Identity();
  ML term = ML::Identity();
  for (int k = 1; k <= 30; ++k) {
    term = (term * M / static_cast<long double>(k)).eval();
    E += term;
  }
  for (int s = 0; s < squarings; ++s) E = (E * E).eval();
  Discretisation<Inputs> d;
  d.Phi = E.template topLeftCorner<4, 4>().template cast<double>();
  d.Gamma0 = E.template block<4, Inputs>(0, 4).template cast<double>();
  d.Gamma1 = E.template block<4, Inputs>(0, 4 + Inputs).template cast<double>();
  return d;
}

// Largest |computed - reference| / |reference| over the non-zero entries of a matrix.
template <class M1, class M2>
double worst_relative(const M1& computed, const M2& reference) {
  double worst = 0.0;
  for (Eigen::Index i = 0; i < reference.rows(); ++i)
    for (Eigen::Index j = 0; j < reference.cols(); ++j)
      if (reference(i, j) != 0.0)
        worst = std::max(worst, std::abs(computed(i, j) - reference(i, j)) / std::abs(reference(i, j)));
      else
        worst = std::max(worst, std::abs(computed(i, j)) > 0.0 ? 1.0 : 0.0);
  return worst;
}

}  // namespace

TEST_CASE("ZOH discretisation of the Golden Car reproduces Sayers' published ST and PR",
          "[vehicle][discretisation]") {
  // The Golden Car per unit sprung mass: k_t/m_s = 653 s^-2, k_s/m_s = 63.3 s^-2, c_s/m_s = 6 s^-1,
  // m_u/m_s = 0.15; state (z_s, z_s', z_u, z_u'), 0.25 m at 80 km/h; ST = exp(A dt),
  // PR = integral over [0, dt] of exp(A s) ds B, the profile held constant over each interval.
  const double K1 = 653.0, K2 = 63.3, C = 6.0, u = 0.15;
  Eigen::Matrix4d A;
  A << 0, 1, 0, 0,     //
      -K2, -C, K2, C,  //
      0, 0, 0, 1,      //
      K2 / u, C / u, -(K1 + K2) / u, -C / u;
  Eigen::Matrix<double, 4, 1> B(0, 0, 0, K1 / u);
  const double dt = 0.25 / (80.0 / 3.6);

  Eigen::Matrix4d ST;
  ST << 0.9966071, 0.01091514, -0.002083274, 0.0003190145,  //
      -0.5563044, 0.9438768, -0.8324718, 0.05064701,        //
      0.02153176, 0.002126763, 0.7508714, 0.008221888,      //
      3.335013, 0.3376467, -39.12762, 0.4347564;
  const Eigen::Vector4d PR(0.005476107, 1.388776, 0.2275968, 35.79262);

  // The published figures are printed to 7 significant digits, but were computed with less
  // precision than that: ST agrees with the exact exponential to ~4e-7 relative and PR to ~2e-5.
  // Those are the tolerances, per entry, relative to the printed value.
  const Discretisation<1> fast = discretise<1>(A, B, dt);
  const Discretisation<1> ref = discretise_expm<1>(A, B, dt);
  const double worst_st = worst_relative(fast.Phi, ST);
  const double worst_pr = worst_relative(fast.Gamma0, PR);
  CHECK(worst_st <= 1e-6);
  CHECK(worst_pr <= 2e-5);
  CHECK(worst_relative(ref.Phi, ST) <= 1e-6);
  CHECK(worst_relative(ref.Gamma0, PR) <= 2e-5);
  WARN("Golden Car: worst relative error ST " << worst_st << " (tolerance 1e-6), PR " << worst_pr
                                              << " (tolerance 2e-5)");
}

TEST_CASE("the Taylor-Horner discretisation is exact to rounding in every entry",
          "[vehicle][discretisation]") {
  QuarterCar car;
  car.tyre_damping_nspm = 2000.0;
  const StateSpace ss = state_space(car);
  // Fine steps and the 5 cm grid at 30 and 23.43 m/s (balanced norm ~0.3: exact to rounding), 5 m/s
  // (norm ~1: small entries lose a few digits to cancellation), and long steps that take the fallback
  // through Eigen's MatrixFunctions (accurate to ~1e-13 relative to the largest entry only).
  struct Case {
    double step_s;
    double tolerance;
  };
  for (const Case c : {Case{1e-5, 2e-15}, Case{0.05 / 30.0, 2e-15}, Case{0.05 / 23.43, 2e-15},
                       Case{0.05 / 5.0, 1e-13}, Case{0.05, 1e-10}, Case{0.2, 1e-10}}) {
    const Discretisation<2> fast = discretise<2>(ss.A, ss.B, c.step_s);
    const Discretisation<2> ref = long_double_reference<2>(ss.A, ss.B, c.step_s);
    INFO("step " << c.step_s << " s: worst relative Phi " << worst_relative(fast.Phi, ref.Phi) << " Gamma0 "
                 << worst_relative(fast.Gamma0, ref.Gamma0) << " Gamma1 "
                 << worst_relative(fast.Gamma1, ref.Gamma1));
    CHECK(worst_relative(fast.Phi, ref.Phi) <= c.tolerance);
    CHECK(worst_relative(fast.Gamma0, ref.Gamma0) <= c.tolerance);
    CHECK(worst_relative(fast.Gamma1, ref.Gamma1) <= c.tolerance);
    // The augmented exponential from MatrixFunctions agrees to ~1e-13 of each row's scale.
    const Discretisation<2> expm = discretise_expm<2>(ss.A, ss.B, c.step_s);
    for (int i = 0; i < 4; ++i) {
      CHECK((expm.Phi.row(i) - ref.Phi.row(i)).cwiseAbs().maxCoeff() <=
            1e-11 * ref.Phi.row(i).cwiseAbs().maxCoeff());
      CHECK((expm.Gamma1.row(i) - ref.Gamma1.row(i)).cwiseAbs().maxCoeff() <=
            1e-11 * ref.Gamma1.row(i).cwiseAbs().maxCoeff());
    }
  }
}

TEST_CASE("discretise rejects a non-positive step", "[vehicle][discretisation]") {
  const StateSpace ss = state_space(QuarterCar{});
  REQUIRE_THROWS_WITH(discretise<2>(ss.A, ss.B, 0.0), Catch::Contains("step_s"));
  REQUIRE_THROWS_WITH(discretise_expm<2>(ss.A, ss.B, -1.0), Catch::Contains("step_s"));
}

TEST_CASE("the IF frequency response vanishes at zero frequency and tends to the bare tyre at high frequency",
          "[vehicle][frequency_response]") {
  const QuarterCar car;
  // A static displacement of the road lifts the whole car: no change of tyre force.
  CHECK(std::abs(impact_factor_response(car, 0.0)) < 1e-12);
  // Far above axle hop the axle cannot follow: IF - 1 -> k_t r / W.
  const double bare = car.tyre_stiffness_npm / car.static_weight_n();
  const std::complex<double> h = impact_factor_response(car, 1e5);
  CHECK(std::abs(h - bare) / bare < 1e-3);
}

TEST_CASE("QuarterCar validation names the offending field", "[vehicle][validation]") {
  QuarterCar car;
  car.sprung_mass_kg = 0.0;
  REQUIRE_THROWS_WITH(validate(car), Catch::Contains("sprung_mass_kg"));
  car = QuarterCar{};
  car.tyre_damping_nspm = -1.0;
  REQUIRE_THROWS_WITH(validate(car), Catch::Contains("tyre_damping_nspm"));
  car = QuarterCar{};
  car.suspension_stiffness_npm = std::nan("");
  REQUIRE_THROWS_WITH(validate(car), Catch::Contains("suspension_stiffness_npm"));
  REQUIRE_NOTHROW(validate(QuarterCar{}));
}

TEST_CASE("QuarterCarBatch stores and returns cars field by field", "[vehicle]") {
  QuarterCarBatch batch;
  batch.assign(3, QuarterCar{});
  QuarterCar other;
  other.sprung_mass_kg = 3000.0;
  other.tyre_damping_nspm = 1500.0;
  batch.set_car(1, other);
  CHECK(batch.size() == 3);
  CHECK(batch.car(1).sprung_mass_kg == 3000.0);
  CHECK(batch.car(1).tyre_damping_nspm == 1500.0);
  CHECK(batch.car(2).sprung_mass_kg == QuarterCar{}.sprung_mass_kg);
  REQUIRE_THROWS(batch.car(3));
}
