// A road surface ("carpet", docs/model.md): heights on a regular grid, x along travel, y across.
// Column-major with one column per lateral line, so a line along travel is contiguous: the
// integrator reads wheel paths straight out of it.
#pragma once

#include <string>

#include <Eigen/Core>

namespace ssrfleet::road {

struct Surface {
  double dx_m = 0.05;          // longitudinal spacing; first sample at x = 0
  double y0_m = 0.0;           // lateral position of the first line
  double dy_m = 0.05;          // lateral spacing between lines
  Eigen::ArrayXXd height_m;    // samples along x (rows) by lateral lines (cols)
  std::string name;            // preset name or source file, for messages and reports

  Eigen::Index samples() const { return height_m.rows(); }
  Eigen::Index lines() const { return height_m.cols(); }
  double length_m() const { return dx_m * static_cast<double>(samples() - 1); }
  double y_max_m() const { return y0_m + dy_m * static_cast<double>(lines() - 1); }
  double lateral_m(Eigen::Index line) const { return y0_m + dy_m * static_cast<double>(line); }
  const double* line(Eigen::Index j) const { return height_m.col(j).data(); }
};

}  // namespace ssrfleet::road
