// Counter-based random streams (the SMCTC / vSMC idea): every random number the SMC engine uses
// comes from a stream keyed by (seed, stage, step, purpose, ..., particle index), so particle i's
// draws are the same whichever thread runs it, and a run is bit-identical for any thread count.
//
// A key is folded into a 64-bit hash with the SplitMix64 finaliser (Steele, Lea & Flood 2014);
// the stream itself is xoshiro256** (Blackman & Vigna 2018), seeded from the hash by SplitMix64.
// Both are tiny and fast, so building a fresh stream per particle per MCMC step costs a few ns.
// Xoshiro256ss satisfies UniformRandomBitGenerator, so Boost.Random (or <random>)
// distributions work on top of it.
#pragma once

#include <cstdint>
#include <limits>

namespace ssrfleet::smc {

// SplitMix64's output function: a bijective 64-bit mixer with full avalanche.
constexpr std::uint64_t splitmix64_mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

inline constexpr std::uint64_t kGoldenGamma = 0x9E3779B97F4A7C15ULL;

// xoshiro256**: 256-bit state, period 2^256 - 1, passes BigCrush.
class Xoshiro256ss {
 public:
  using result_type = std::uint64_t;
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return std::numeric_limits<result_type>::max(); }

  // The state is filled from a SplitMix64 sequence started at `seed`, as the authors recommend.
  explicit constexpr Xoshiro256ss(std::uint64_t seed) {
    for (int j = 0; j < 4; ++j) {
      seed += kGoldenGamma;
      s_[j] = splitmix64_mix(seed);
    }
  }

  constexpr result_type operator()() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4] = {};
};

using Rng = Xoshiro256ss;

// A uniform double in [0, 1) from the top 53 bits (exact, platform independent; Boost's
// uniform_01 would do too, but this one is fixed forever, so saved outputs stay valid).
inline double uniform01(Rng& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// A node in a tree of streams: child(k) descends one level, stream(i) gives particle i's
// generator. Keys are folded in order, so child(a).child(b) differs from child(b).child(a).
// A value type (one 64-bit word): pass it by value or const reference to worker threads.
class RngFactory {
 public:
  explicit constexpr RngFactory(std::uint64_t seed) : key_(splitmix64_mix(seed + kGoldenGamma)) {}

  constexpr RngFactory child(std::uint64_t key) const { return RngFactory(fold(key_, key), Tag{}); }
  template <class... Keys>
  constexpr RngFactory child(std::uint64_t first, Keys... rest) const {
    RngFactory f = child(first);
    ((f = f.child(static_cast<std::uint64_t>(rest))), ...);
    return f;
  }

  // The generator for one index (usually a particle index) below this node.
  constexpr Rng stream(std::uint64_t index) const { return Rng(fold(key_, index)); }

  constexpr std::uint64_t key() const { return key_; }

 private:
  struct Tag {};
  constexpr RngFactory(std::uint64_t key, Tag) : key_(key) {}
  static constexpr std::uint64_t fold(std::uint64_t h, std::uint64_t k) {
    return splitmix64_mix(h ^ splitmix64_mix(k + kGoldenGamma));
  }
  std::uint64_t key_;
};

}  // namespace ssrfleet::smc
