// Longitudinal road profiles without a lateral grid: what a profilometer measures in each wheel
// path and what an ERD file holds (erd_format.hpp). A profile is enough for roughness (IRI, the
// PSD fit, the ISO 8608 class); it is not a 3-D surface, since nothing says where across the road
// each profile lies, so the commands that drive trucks across a surface do not take one.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace ssrfleet::road {

struct LongitudinalProfiles {
  std::string name;                 // source file, for messages and reports
  double dx_m = 0.05;               // sample spacing along travel; first sample at x = 0
  std::vector<std::string> labels;  // one per profile ("left", "z=1.6m", ...)
  Eigen::ArrayXXd height_m;         // samples (rows) by profiles (columns), metres

  Eigen::Index samples() const { return height_m.rows(); }
  Eigen::Index profiles() const { return height_m.cols(); }
  double length_m() const { return dx_m * static_cast<double>(samples() - 1); }
};

}  // namespace ssrfleet::road
