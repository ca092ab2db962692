// Runs quarter cars at constant speed over a wheel path and returns the impact factor (IF) at
// chosen longitudinal positions. The system is linear time-invariant per truck, so each step
// uses the exact discretisation (matrix exponential) with the profile read as a continuous
// surface, linear between samples (first-order hold): a staircase would shift the profile by
// half a sample and bias IF by ~3e-3 at 5 cm spacing.
//
// The car starts at static equilibrium on the path's first sample (x = 0) and travels to the
// last output position. An output position between two samples is reached by an exact partial
// step, so any position works, on the sample grid or off it.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "vehicle/line_bundle.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::vehicle {

namespace pass_kernel {
struct TruckCoefficients;
struct PartialCoefficients;
}  // namespace pass_kernel

// The wheel path of one pass: r_j = (1 - weight_b) * line_a[j] + weight_b * line_b[j], j = 0 ..
// samples-1, sample spacing dx_m. A path already extracted is {p, p, 0}. Lateral interpolation
// on the fly lets a batch of trucks at different lateral positions share one road surface
// without copying it.
struct WheelPath {
  const double* line_a = nullptr;
  const double* line_b = nullptr;
  double weight_b = 0.0;
};

// run_batch() advances trucks in blocks of this many, in lock-step (the benchmark's floor kernel
// uses the same block so the comparison is like for like); a batch of at most 4 or 8 trucks runs
// in a block of 4 or 8.
inline constexpr int batch_block_trucks = 16;

// Per-pass extra output: the minimum IF over the whole pass (start to last output position).
// IF < 0 means the tyre force went negative (wheel lift-off): reported, never hidden.
struct PassExtremes {
  double min_if = 0.0;
};

class PassIntegrator {
 public:
  // samples: number of profile samples per line, spacing dx_m, first sample at x = 0.
  // positions_m: output positions, strictly increasing, each within [0, (samples-1)*dx_m];
  // otherwise std::invalid_argument naming the first bad position.
  PassIntegrator(double dx_m, Eigen::Index samples, std::vector<double> positions_m);

  const std::vector<double>& positions_m() const { return positions_m_; }
  double dx_m() const { return dx_m_; }
  Eigen::Index samples() const { return samples_; }

  // One truck. if_out.size() must equal positions_m().size().
  PassExtremes run(const QuarterCar& car, double speed_mps, const WheelPath& path,
                   Eigen::Ref<Eigen::VectorXd> if_out) const;

  // Many trucks in lock-step (structure of arrays, vectorised across trucks). if_out is
  // positions x trucks (one column per truck); min_if_out, if non-null, gets one value per truck.
  // Agrees with run() to 1e-12.
  void run_batch(const QuarterCarBatch& cars, const Eigen::ArrayXd& speed_mps,
                 const std::vector<WheelPath>& paths, Eigen::Ref<Eigen::ArrayXXd> if_out,
                 Eigen::ArrayXd* min_if_out = nullptr) const;

  // Many cars at one speed, each over every line of `lines` (pass_lines.cpp): if_out is
  // positions x (cars x lines), car-major (column c * lines.lines() + l). Per pass the same
  // expressions as run_batch on the path {line, line, 0}, without the pass minimum; 1.9x faster
  // per pass on 64 cars sharing 8 lines (a truck table's nodes; integrator_benchmark).
  void run_on_lines(const QuarterCarBatch& cars, double speed_mps, const LineBundle& lines,
                    Eigen::Ref<Eigen::ArrayXXd> if_out) const;

 private:
  double dx_m_;
  Eigen::Index samples_;
  std::vector<double> positions_m_;
  // Implementation detail decided by the integrator: e.g. per position, the sample index before
  // it and the fraction of a step beyond it.
  std::vector<Eigen::Index> position_sample_;
  std::vector<double> position_fraction_;
  // The distinct non-zero fractions (one partial-step discretisation per truck for each), and per
  // position the index into it, or -1 for a position on the sample grid.
  std::vector<double> distinct_fractions_;
  std::vector<int> position_fraction_slot_;

  // run_batch()'s kernel, BS trucks per block (4, 8 or batch_block_trucks).
  template <int BS>
  void run_blocks(const QuarterCarBatch& cars, const Eigen::ArrayXd& speed_mps, const std::vector<WheelPath>& paths,
                  Eigen::Ref<Eigen::ArrayXXd> if_out, Eigen::ArrayXd* min_if_out) const;
  // run_on_lines()'s kernel: cars first_car .. first_car + cars - 1 (cars <= C) on `lanes` lines
  // from lane0, in a block of LW lanes per car; coefficients and partial (nfrac per car) hold
  // every car's discretisation.
  template <int LW, int C>
  void run_lane_block(const pass_kernel::TruckCoefficients* coefficients,
                      const pass_kernel::PartialCoefficients* partial, Eigen::Index first_car, int cars,
                      const LineBundle& bundle, int lane0, int lanes, Eigen::Ref<Eigen::ArrayXXd> if_out) const;
};

}  // namespace ssrfleet::vehicle
