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

double multi_chain_effective_sample_size(const Eigen::Ref<const Eigen::MatrixXd>& chains) {
  const Eigen::Index n = chains.rows(), m = chains.cols();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (n < 4 || m < 1 || !chains.allFinite() || chains.maxCoeff() == chains.minCoeff()) return nan;
  const auto n_draws = static_cast<double>(n);
  // Mean over the chains of each chain's autocovariances, and the chains' means.
  Eigen::VectorXd mean_acov = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd chain_means(m);
  for (Eigen::Index c = 0; c < m; ++c) {
    mean_acov += autocovariance(chains.col(c), n - 1);
    chain_means[c] = chains.col(c).mean();
  }
  mean_acov /= static_cast<double>(m);
  const double within = mean_acov[0] * n_draws / (n_draws - 1.0);  // W
  double var_plus = within * (n_draws - 1.0) / n_draws;
  if (m > 1)
    var_plus += (chain_means.array() - chain_means.mean()).square().sum() / static_cast<double>(m - 1);
  if (!(var_plus > 0.0)) return nan;
  const auto rho_at = [&](Eigen::Index t) { return 1.0 - (within - mean_acov[t]) / var_plus; };

  // Initial positive sequence: pairs (ρ(t), ρ(t+1)), t even, kept while their sum is >= 0 and
  // taken while the previous pair's sum was > 0, up to even lag n - 4.
  Eigen::VectorXd rho = Eigen::VectorXd::Zero(n);
  double even = 1.0, odd = rho_at(1);
  rho[0] = even;
  rho[1] = odd;
  Eigen::Index t = 0;
  while (t < n - 5 && even + odd > 0.0) {
    t += 2;
    even = rho_at(t);
    odd = rho_at(t + 1);
    if (even + odd >= 0.0) {
      rho[t] = even;
      rho[t + 1] = odd;
    }
  }
  const Eigen::Index last = t;  // even lag of the first pair not summed
  if (even > 0.0) rho[last] = even;
  // Initial monotone sequence: each pair clipped to the one before it.
  for (Eigen::Index k = 2; k + 2 <= last; k += 2) {
    const double previous = rho[k - 2] + rho[k - 1];
    if (rho[k] + rho[k + 1] > previous) rho[k] = rho[k + 1] = previous / 2.0;
  }
  const double total = n_draws * static_cast<double>(m);
  const double tau = std::max(-1.0 + 2.0 * rho.head(last).sum() + rho[last], 1.0 / std::log10(total));
  return total / tau;
}

double chain_effective_sample_size(const Eigen::Ref<const Eigen::VectorXd>& chain) {
  return multi_chain_effective_sample_size(chain);
}

}  // namespace ssrfleet
