#include "road/psd_estimate.hpp"

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "util/check.hpp"

namespace ssrfleet::road {

namespace {

// Removes the least-squares straight line (in place).
void detrend_linear(Eigen::ArrayXd& y) {
  const auto n = static_cast<double>(y.size());
  const Eigen::ArrayXd t = Eigen::ArrayXd::LinSpaced(y.size(), 0.0, n - 1.0) - 0.5 * (n - 1.0);
  const double slope = (t * y).sum() / t.square().sum();
  y -= y.mean() + slope * t;
}

// Accumulates |FFT|^2 of detrended, windowed segments of one profile into `power`.
class WelchAccumulator {
 public:
  WelchAccumulator(Eigen::Index segment, double dx_m) : segment_(segment), dx_m_(dx_m) {
    // Hann window (periodic form is not needed: segments are not concatenated).
    const Eigen::ArrayXd k = Eigen::ArrayXd::LinSpaced(segment, 0.0, static_cast<double>(segment - 1));
    window_ = 0.5 - 0.5 * (2.0 * std::numbers::pi * k / static_cast<double>(segment - 1)).cos();
    power_ = Eigen::ArrayXd::Zero(segment / 2);
  }

  void add_profile(const Eigen::Ref<const Eigen::ArrayXd>& profile) {
    const Eigen::Index n = profile.size();
    if (segment_ > n) throw std::invalid_argument("welch_psd: segment is longer than the profile");
    const Eigen::Index step = std::max<Eigen::Index>(1, segment_ / 2);
    for (Eigen::Index start = 0; start + segment_ <= n; start += step) {
      Eigen::ArrayXd y = profile.segment(start, segment_);
      detrend_linear(y);
      y *= window_;
      fft_.fwd(spectrum_, std::vector<double>(y.data(), y.data() + y.size()));
      for (Eigen::Index k = 1; k <= segment_ / 2; ++k) power_(k - 1) += std::norm(spectrum_[static_cast<std::size_t>(k)]);
      ++segments_;
    }
  }

  Psd result() const {
    Psd psd;
    const double length_m = static_cast<double>(segment_) * dx_m_;
    psd.frequency_cpm = Eigen::ArrayXd::LinSpaced(segment_ / 2, 1.0, static_cast<double>(segment_ / 2)) / length_m;
    // One-sided: 2 |X_k|^2 dx / sum(w^2); the Nyquist ordinate (even segment) has no mirror.
    psd.density_m3 = power_ * (2.0 * dx_m_ / (window_.square().sum() * static_cast<double>(segments_)));
    if (segment_ % 2 == 0) psd.density_m3(segment_ / 2 - 1) *= 0.5;
    return psd;
  }

 private:
  Eigen::Index segment_;
  double dx_m_;
  Eigen::ArrayXd window_;
  Eigen::ArrayXd power_;
  Eigen::FFT<double> fft_;
  std::vector<std::complex<double>> spectrum_;
  long segments_ = 0;
};

}  // namespace

Psd welch_psd(const Eigen::ArrayXd& profile_m, double dx_m, Eigen::Index segment_samples) {
  check_positive("welch_psd", "dx_m", dx_m);
  const Eigen::Index segment = segment_samples == 0 ? profile_m.size() : segment_samples;
  if (segment < 4) throw std::invalid_argument("welch_psd: need at least 4 samples per segment");
  WelchAccumulator acc(segment, dx_m);
  acc.add_profile(profile_m);
  return acc.result();
}

Psd mean_psd_along_x(const Surface& surface) {
  if (surface.samples() < 4) throw std::invalid_argument("mean_psd_along_x: need at least 4 samples");
  WelchAccumulator acc(surface.samples(), surface.dx_m);
  for (Eigen::Index j = 0; j < surface.lines(); ++j) acc.add_profile(surface.height_m.col(j));
  return acc.result();
}

Psd mean_psd_along_y(const Surface& surface) {
  if (surface.lines() < 4) throw std::invalid_argument("mean_psd_along_y: need at least 4 lines");
  WelchAccumulator acc(surface.lines(), surface.dy_m);
  for (Eigen::Index i = 0; i < surface.samples(); ++i) {
    const Eigen::ArrayXd row = surface.height_m.row(i).transpose();
    acc.add_profile(row);
  }
  return acc.result();
}

PsdFit fit_power_law(const Psd& psd, double n_lo_cpm, double n_hi_cpm, double n0_cpm) {
  check_positive("fit_power_law", "n_lo_cpm", n_lo_cpm);
  check_positive("fit_power_law", "n0_cpm", n0_cpm);
  if (!(n_hi_cpm > n_lo_cpm)) throw std::invalid_argument("fit_power_law: n_hi_cpm must exceed n_lo_cpm");
  constexpr double kBinsPerDecade = 10.0;
  const auto nbins = static_cast<Eigen::Index>(std::ceil(kBinsPerDecade * std::log10(n_hi_cpm / n_lo_cpm)));
  Eigen::ArrayXd sum_density = Eigen::ArrayXd::Zero(nbins);
  Eigen::ArrayXd sum_log_n = Eigen::ArrayXd::Zero(nbins);
  Eigen::ArrayXi count = Eigen::ArrayXi::Zero(nbins);
  for (Eigen::Index k = 0; k < psd.frequency_cpm.size(); ++k) {
    const double n = psd.frequency_cpm(k);
    if (n < n_lo_cpm || n > n_hi_cpm) continue;
    const auto b = std::min<Eigen::Index>(nbins - 1, static_cast<Eigen::Index>(kBinsPerDecade * std::log10(n / n_lo_cpm)));
    sum_density(b) += psd.density_m3(k);
    sum_log_n(b) += std::log(n / n0_cpm);
    ++count(b);
  }
  std::vector<double> xs, ys, ws;
  for (Eigen::Index b = 0; b < nbins; ++b) {
    if (count(b) == 0) continue;
    xs.push_back(sum_log_n(b) / count(b));
    ys.push_back(std::log(sum_density(b) / count(b)));
    ws.push_back(count(b));
  }
  if (xs.size() < 3) throw std::invalid_argument("fit_power_law: fewer than 3 frequency bins in the band");
  // Copied into Eigen's own storage, not mapped: Eigen vectorises a sum over a mapped pointer from
  // its first aligned element, so a sum over a std::vector's heap address would change in its last
  // bits with where the allocator put it.
  const Eigen::ArrayXd x = Eigen::Map<const Eigen::ArrayXd>(xs.data(), static_cast<Eigen::Index>(xs.size()));
  const Eigen::ArrayXd y = Eigen::Map<const Eigen::ArrayXd>(ys.data(), static_cast<Eigen::Index>(ys.size()));
  const Eigen::ArrayXd wt = Eigen::Map<const Eigen::ArrayXd>(ws.data(), static_cast<Eigen::Index>(ws.size()));
  const double xm = (wt * x).sum() / wt.sum();
  const double ym = (wt * y).sum() / wt.sum();
  const double slope = (wt * (x - xm) * (y - ym)).sum() / (wt * (x - xm).square()).sum();
  PsdFit fit;
  fit.waviness = -slope;
  fit.gd_n0_m3 = std::exp(ym - slope * xm);
  fit.n0_cpm = n0_cpm;
  fit.bins = static_cast<int>(xs.size());
  return fit;
}

PsdFit fit_psd(const Surface& surface, double n_lo_cpm, double n_hi_cpm, double n0_cpm) {
  return fit_power_law(mean_psd_along_x(surface), n_lo_cpm, n_hi_cpm, n0_cpm);
}

PsdFit fit_psd_across(const Surface& surface, double n_lo_cpm, double n_hi_cpm, double n0_cpm) {
  return fit_power_law(mean_psd_along_y(surface), n_lo_cpm, n_hi_cpm, n0_cpm);
}

}  // namespace ssrfleet::road
