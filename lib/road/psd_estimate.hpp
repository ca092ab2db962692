// Estimating the one-sided displacement PSD of road profiles and fitting the ISO 8608 power law
// G_d(n) = G_d(n0) (n/n0)^-w to it.
#pragma once

#include <Eigen/Core>

#include "road/surface.hpp"

namespace ssrfleet::road {

// One-sided PSD: density_m3(k) at frequency_cpm(k) = k / (segment * dx), k = 1 .. segment/2
// (the mean, k = 0, is left out: it is removed by the detrending).
struct Psd {
  Eigen::ArrayXd frequency_cpm;
  Eigen::ArrayXd density_m3;
};

// Welch estimate: segments of `segment_samples` (0 = the whole profile, i.e. one windowed
// periodogram) overlapping by half; each segment has its least-squares line removed (a road
// profile's slope would leak into every bin) and a Hann window applied; scaled so that the
// integral of the density over (0, Nyquist] is the variance. Throws std::invalid_argument for
// fewer than 4 samples, dx <= 0 or a segment longer than the profile.
Psd welch_psd(const Eigen::ArrayXd& profile_m, double dx_m, Eigen::Index segment_samples = 0);

// The PSD along travel averaged over every line of the surface (whole-line periodograms).
Psd mean_psd_along_x(const Surface& surface);
// The PSD across travel (each row x = const as a profile in y, spacing dy) averaged over rows.
Psd mean_psd_along_y(const Surface& surface);

struct PsdFit {
  double gd_n0_m3 = 0.0;   // fitted G_d(n0)
  double waviness = 0.0;   // fitted w
  double n0_cpm = 0.1;
  int bins = 0;            // log-spaced bins used in the fit
};

// Least squares of log G = log G(n0) - w log(n/n0) over log-spaced bins (10 per decade) between
// n_lo and n_hi: each bin's value is the mean density of the PSD ordinates in it (an unbiased
// mean before the log) at the geometric mean of their frequencies; each non-empty bin counts
// once, so every part of the band weighs the same. Throws std::invalid_argument if the band is
// empty or fewer than 3 bins hold ordinates.
PsdFit fit_power_law(const Psd& psd, double n_lo_cpm, double n_hi_cpm, double n0_cpm = 0.1);

// fit_power_law(mean_psd_along_x(surface), ...) and the same across lines (isotropy check).
PsdFit fit_psd(const Surface& surface, double n_lo_cpm, double n_hi_cpm, double n0_cpm = 0.1);
PsdFit fit_psd_across(const Surface& surface, double n_lo_cpm, double n_hi_cpm, double n0_cpm = 0.1);

}  // namespace ssrfleet::road
