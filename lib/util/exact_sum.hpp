// A sum of doubles whose bits do not depend on the order the terms come in, nor on how they were
// split into partial sums: each term is rounded once onto a fixed grid (2^-kFractionBits) and the
// grid values are added as 128-bit integers, which is associative. The fleet posterior's
// Σ_i ℓ_i(θ) is one (model/fleet_marginal.hpp): whether one thread sums every truck, or four MPI
// ranks each sum their own trucks and the partial sums are added in whatever order the network
// delivers them, a seed gives the same bits (docs/sites.md).
//
// The grid, 2^-48 ≈ 3.6e-15, is finer than a double's own spacing for any |ℓ| of 16 or more, and
// the rounding error per term (at most 1.8e-15) is nine orders below the single-precision node
// sums' own (1.6e-6 nats per truck). Range: a term's |x| must stay below 2^50 ≈ 1.1e15; a term
// below -2^50 is a density of zero and makes the sum -inf (as a -inf term does); a NaN term makes
// it NaN unless a term is -inf (a numerical failure the caller must see, not a particle quietly
// dropped; -inf wins, so a sum that stops at its first -inf term has the bits of one that does
// not, whatever the order of the terms or their split between ranks); a term above
// +2^50 is a bug (a log-likelihood that large is impossible) and throws. With at most 2^28 terms
// (268 million trucks) the 128-bit total cannot overflow.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace ssrfleet::util {

class ExactSum {
 public:
  static constexpr int kFractionBits = 48;
  static constexpr double kMaxTerm = 0x1p50;
  static constexpr double kScale = 0x1p48;  // 2^kFractionBits

  void add(double x) {
    if (std::isnan(x)) {
      ++nans_;
      return;
    }
    if (x < -kMaxTerm) {  // -inf, or a density of zero
      ++minus_infinities_;
      return;
    }
    if (x > kMaxTerm) throw std::overflow_error("ExactSum: a term above 2^50");
    // Scaling by a power of two is exact; |x| 2^48 < 2^98, so nearbyint's result is an
    // integer-valued double that the conversion keeps exactly.
    total_ += static_cast<Int>(std::nearbyint(x * kScale));
  }
  void add(const ExactSum& other) {
    total_ += other.total_;
    minus_infinities_ += other.minus_infinities_;
    nans_ += other.nans_;
  }
  // No term will change the value any more (a term was -inf): a caller may skip the rest.
  bool settled() const { return minus_infinities_ != 0; }
  // The sum, rounded once to the nearest double: -inf if any term was, else NaN if any term was.
  double value() const {
    if (minus_infinities_ != 0) return -std::numeric_limits<double>::infinity();
    if (nans_ != 0) return std::numeric_limits<double>::quiet_NaN();
    return static_cast<double>(total_) / kScale;
  }

  // The raw state as four 64-bit words (the total's low and high halves, the counts of -inf and of
  // NaN terms): what an MPI reduction sends and adds (add_words), word for word.
  static constexpr int kWords = 4;
  void to_words(std::uint64_t* w) const {
    const auto u = static_cast<UInt>(total_);
    w[0] = static_cast<std::uint64_t>(u);
    w[1] = static_cast<std::uint64_t>(u >> 64);
    w[2] = minus_infinities_;
    w[3] = nans_;
  }
  static ExactSum from_words(const std::uint64_t* w) {
    ExactSum s;
    s.total_ = static_cast<Int>((static_cast<UInt>(w[1]) << 64) | w[0]);
    s.minus_infinities_ = w[2];
    s.nans_ = w[3];
    return s;
  }
  // into += from, for sums in word form (two's complement: the carry of the low word goes up).
  static void add_words(const std::uint64_t* from, std::uint64_t* into) {
    const std::uint64_t low = into[0] + from[0];
    into[1] += from[1] + (low < from[0] ? 1u : 0u);
    into[0] = low;
    into[2] += from[2];
    into[3] += from[3];
  }

 private:
  __extension__ using Int = __int128;
  __extension__ using UInt = unsigned __int128;
  Int total_ = 0;
  std::uint64_t minus_infinities_ = 0, nans_ = 0;
};

}  // namespace ssrfleet::util
