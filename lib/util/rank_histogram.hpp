// Rank statistics of simulation-based calibration (Talts, Betancourt, Simpson, Vehtari & Gelman
// 2018, "Validating Bayesian inference algorithms with simulation-based calibration",
// arXiv:1804.06788, Algorithm 1): draw θ from the prior, data from θ, L posterior draws given the
// data; the rank of θ among the L draws, #{l : θ_l < θ} ∈ {0, ..., L}, is uniform over its L + 1
// values for every prior draw exactly when the posterior draws are independent draws from the
// true posterior. A rank histogram over R replications is then R draws of a uniform, and a
// deviation (a ∪ or ∩ shape: posterior too narrow or too wide; a slope: biased) shows a sampler
// or a model that disagrees with the simulator.
//
// The histogram joins the L + 1 rank values into B bins of (L + 1) / B values each (so B must
// divide L + 1: every bin then has the same probability 1 / B). Its uniformity is judged by
// Pearson's χ² test with B − 1 degrees of freedom, and each bin's count is shown against the
// central interval of Binomial(R, 1 / B), the band a uniform histogram's bins fall in.
#pragma once

#include <vector>

namespace ssrfleet {

// #{draws < truth}: the SBC rank, in [0, draws.size()]. A draw equal to the truth is not counted
// (with continuous draws this has probability 0).
int sbc_rank(double truth, const std::vector<double>& draws);

// Counts of `ranks` (each in [0, draws]) in `bins` equal bins: rank r falls in bin
// r / ((draws + 1) / bins). UsageError unless bins >= 2 divides draws + 1 and every rank is in range.
std::vector<int> rank_histogram(const std::vector<int>& ranks, int draws, int bins);

struct ChiSquareUniformity {
  double statistic = 0.0;   // Σ_b (n_b − R/B)² / (R/B)
  int degrees_of_freedom = 0;  // B − 1
  double p_value = 1.0;     // P(χ²(B − 1) ≥ statistic), Boost.Math's chi_squared complement cdf
};

// Pearson's χ² test of equal bin probabilities. UsageError for fewer than 2 bins, a negative
// count or an empty histogram. (The χ² law is an approximation that is good when every expected
// count R/B is at least about 5.)
ChiSquareUniformity chi_square_uniformity(const std::vector<int>& counts);

// The central `level` interval [lo, hi] of Binomial(n, p): lo is the largest k with
// P(X < k) <= (1 − level)/2, hi the smallest k with P(X > k) <= (1 − level)/2, so the interval
// holds at least `level` of the mass. For a rank histogram: n = R, p = 1/B.
struct CountInterval {
  int lo = 0;
  int hi = 0;
};
CountInterval binomial_central_interval(int n, double p, double level);

}  // namespace ssrfleet
