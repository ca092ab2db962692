#include "smc/resampling.hpp"

#include <cmath>
#include <stdexcept>

#include "util/errors.hpp"

namespace ssrfleet::smc {

namespace {

// Inverse CDF of W at sorted points u (each in [0, 1)): one pass over both.
std::vector<Eigen::Index> inverse_cdf(const std::vector<double>& u, const Eigen::Ref<const Eigen::ArrayXd>& W) {
  std::vector<Eigen::Index> a(u.size());
  const Eigen::Index P = W.size();
  Eigen::Index j = 0;
  double cumulative = W[0];
  for (std::size_t k = 0; k < u.size(); ++k) {
    // The last cumulative sum may round below 1: never run past the last particle.
    while (u[k] >= cumulative && j < P - 1) cumulative += W[++j];
    a[k] = j;
  }
  return a;
}

void check_inputs(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M) {
  if (W.size() == 0) throw std::invalid_argument("resample: no weights");
  if (M < 0) throw std::invalid_argument("resample: negative number of draws");
  if (!((W >= 0.0).all() && std::isfinite(W.sum()) && W.sum() > 0.0))
    throw NumericalError("resample: weights must be finite, non-negative and not all zero");
}

}  // namespace

std::string_view to_string(ResamplingScheme scheme) {
  switch (scheme) {
    case ResamplingScheme::systematic: return "systematic";
    case ResamplingScheme::stratified: return "stratified";
    case ResamplingScheme::multinomial: return "multinomial";
    case ResamplingScheme::residual: return "residual";
  }
  return "unknown";
}

ResamplingScheme resampling_scheme_from_string(std::string_view name) {
  for (auto s : {ResamplingScheme::systematic, ResamplingScheme::stratified, ResamplingScheme::multinomial,
                 ResamplingScheme::residual})
    if (to_string(s) == name) return s;
  throw UsageError("resampling scheme '" + std::string(name) +
                   "' is unknown; use systematic, stratified, multinomial or residual");
}

std::vector<Eigen::Index> systematic_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng) {
  check_inputs(W, M);
  const double u0 = uniform01(rng);
  std::vector<double> u(static_cast<std::size_t>(M));
  for (Eigen::Index k = 0; k < M; ++k) u[static_cast<std::size_t>(k)] = (static_cast<double>(k) + u0) / static_cast<double>(M);
  return inverse_cdf(u, W / W.sum());
}

std::vector<Eigen::Index> stratified_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng) {
  check_inputs(W, M);
  std::vector<double> u(static_cast<std::size_t>(M));
  for (Eigen::Index k = 0; k < M; ++k)
    u[static_cast<std::size_t>(k)] = (static_cast<double>(k) + uniform01(rng)) / static_cast<double>(M);
  return inverse_cdf(u, W / W.sum());
}

std::vector<Eigen::Index> multinomial_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng) {
  check_inputs(W, M);
  // Sorted uniforms: normalised partial sums of M + 1 standard exponentials (Devroye 1986, V.3).
  std::vector<double> u(static_cast<std::size_t>(M));
  double total = 0.0;
  for (auto& x : u) {
    total += -std::log1p(-uniform01(rng));
    x = total;
  }
  total += -std::log1p(-uniform01(rng));
  for (auto& x : u) x /= total;
  return inverse_cdf(u, W / W.sum());
}

std::vector<Eigen::Index> residual_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng) {
  check_inputs(W, M);
  const Eigen::ArrayXd MW = static_cast<double>(M) * W / W.sum();
  const Eigen::ArrayXd copies = MW.floor();
  std::vector<Eigen::Index> a;
  a.reserve(static_cast<std::size_t>(M));
  for (Eigen::Index i = 0; i < W.size(); ++i)
    for (Eigen::Index c = 0; c < static_cast<Eigen::Index>(copies[i]); ++c) a.push_back(i);
  const Eigen::Index R = M - static_cast<Eigen::Index>(a.size());
  if (R > 0) {
    const std::vector<Eigen::Index> rest = multinomial_resampling(MW - copies, R, rng);
    std::vector<Eigen::Index> merged;
    merged.reserve(static_cast<std::size_t>(M));
    std::size_t p = 0, q = 0;  // merge two sorted lists, keeping the output non-decreasing
    while (p < a.size() || q < rest.size())
      merged.push_back((q == rest.size() || (p < a.size() && a[p] <= rest[q])) ? a[p++] : rest[q++]);
    a.swap(merged);
  }
  return a;
}

std::vector<Eigen::Index> resample(ResamplingScheme scheme, const Eigen::Ref<const Eigen::ArrayXd>& W,
                                   Eigen::Index M, Rng& rng) {
  switch (scheme) {
    case ResamplingScheme::systematic: return systematic_resampling(W, M, rng);
    case ResamplingScheme::stratified: return stratified_resampling(W, M, rng);
    case ResamplingScheme::multinomial: return multinomial_resampling(W, M, rng);
    case ResamplingScheme::residual: return residual_resampling(W, M, rng);
  }
  throw std::invalid_argument("resample: unknown scheme");
}

}  // namespace ssrfleet::smc
