#include "util/effective_sample_size.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include <unsupported/Eigen/FFT>

namespace ssrfleet {

Eigen::VectorXd autocovariance(const Eigen::Ref<const Eigen::VectorXd>& chain, Eigen::Index max_lag) {
  const Eigen::Index n = chain.size();
  max_lag = std::clamp<Eigen::Index>(max_lag, 0, n > 0 ? n - 1 : 0);
  Eigen::VectorXd acov = Eigen::VectorXd::Zero(max_lag + 1);
  if (n == 0) return acov;
  // Zero-pad to a power of two >= 2n so the circular correlation equals the linear one.
  Eigen::Index size = 1;
  while (size < 2 * n) size *= 2;
  const double mean = chain.mean();
  std::vector<double> padded(static_cast<std::size_t>(size), 0.0);
  for (Eigen::Index i = 0; i < n; ++i) padded[static_cast<std::size_t>(i)] = chain[i] - mean;
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, padded);
  for (auto& c : spectrum) c = std::complex<double>(std::norm(c), 0.0);
  std::vector<double> circular;
  fft.inv(circular, spectrum);
  for (Eigen::Index t = 0; t <= max_lag; ++t)
    acov[t] = circular[static_cast<std::size_t>(t)] / static_cast<double>(n);
  return acov;
}

double chain_effective_sample_size(const Eigen::Ref<const Eigen::VectorXd>& chain) {
  const Eigen::Index n = chain.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (n < 4 || !chain.allFinite()) return nan;
  const Eigen::VectorXd acov = autocovariance(chain, n - 1);
  const double gamma0 = acov[0];
  if (!(gamma0 > 0.0) || gamma0 <= 1e-28 * chain.squaredNorm() / static_cast<double>(n)) return nan;
  // Initial positive sequence, made monotone (Geyer's initial monotone sequence estimator).
  double sum = 0.0, previous = std::numeric_limits<double>::infinity();
  for (Eigen::Index m = 0; 2 * m + 1 < n; ++m) {
    double pair = acov[2 * m] + acov[2 * m + 1];
    if (!(pair > 0.0)) break;
    pair = std::min(pair, previous);
    sum += pair;
    previous = pair;
  }
  const double tau = std::max(-1.0 + 2.0 * sum / gamma0, 1.0 / std::log10(static_cast<double>(n)));
  return static_cast<double>(n) / tau;
}

}  // namespace ssrfleet
