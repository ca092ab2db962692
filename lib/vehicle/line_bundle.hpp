// Consecutive surface lines, their heights transposed once to [sample][line] so that many cars
// can run over the same lines (PassIntegrator::run_on_lines). A truck table runs every one of its
// (k, k_t) nodes over the same few lateral lines; read through WheelPaths, each block of passes
// gathered and transposed its lanes' heights again.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace ssrfleet::vehicle {

class LineBundle {
 public:
  // lines: pointers to each line's samples (samples each, x = 0 upwards), in lane order.
  // std::invalid_argument if there are none, or one is null, or samples < 2.
  LineBundle(const std::vector<const double*>& lines, Eigen::Index samples);

  int lines() const { return lines_; }
  // Lanes per sample row: lines() rounded up to a multiple of 4 (padding lanes repeat
  // the last line; their results are dropped).
  int lanes() const { return lanes_; }
  Eigen::Index samples() const { return heights_.cols(); }
  // The heights of every lane at sample j (lanes() values).
  const double* row(Eigen::Index j) const { return heights_.col(j).data(); }

 private:
  int lines_ = 0;
  int lanes_ = 0;
  Eigen::ArrayXXd heights_;  // lanes x samples: one column per sample
};

}  // namespace ssrfleet::vehicle
