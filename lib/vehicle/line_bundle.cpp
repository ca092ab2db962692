#include "vehicle/line_bundle.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ssrfleet::vehicle {

namespace {
// Lanes come in multiples of this (one AVX2 register of doubles, half an AVX-512 one): the
// kernel's blocks are 4 to 32 lanes wide in steps of 4, and a block reads its padding lanes.
constexpr int kLaneMultiple = 4;
}  // namespace

LineBundle::LineBundle(const std::vector<const double*>& lines, Eigen::Index samples) {
  if (lines.empty()) throw std::invalid_argument("LineBundle: no lines");
  if (samples < 2) throw std::invalid_argument("LineBundle: samples must be at least 2, got " + std::to_string(samples));
  for (std::size_t l = 0; l < lines.size(); ++l)
    if (lines[l] == nullptr) throw std::invalid_argument("LineBundle: line " + std::to_string(l) + " is null");
  lines_ = static_cast<int>(lines.size());
  lanes_ = (lines_ + kLaneMultiple - 1) / kLaneMultiple * kLaneMultiple;
  heights_.resize(lanes_, samples);
  for (int t = 0; t < lanes_; ++t) {
    const double* line = lines[static_cast<std::size_t>(std::min(t, lines_ - 1))];
    for (Eigen::Index j = 0; j < samples; ++j) heights_(t, j) = line[j];
  }
}

}  // namespace ssrfleet::vehicle
