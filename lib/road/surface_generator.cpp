// Cebon & Newland (1984) random-phase synthesis of an isotropic surface, with the 2-D spectrum
// derived from the 1-D line spectrum of ISO 8608 / BS 7853.
//
// Derivation. Let S2(n, m) be the two-sided 2-D PSD (n along x, m along y, cycle/m). The PSD of
// the heights along a line y = const is the marginal  S1(n) = ∫ S2(n, m) dm,  and the one-sided
// G_d(n) = 2 S1(n). For an isotropic field S2 depends on kappa = sqrt(n² + m²) only. Trying
// S2 = C kappa^-(w+1) and substituting m = n t:
//   S1(n) = C n^-w ∫ (1 + t²)^-(w+1)/2 dt = C n^-w sqrt(pi) Gamma(w/2) / Gamma((w+1)/2),
// a power law of slope -w as required (for w = 2 the integral is exactly 2). Matching
// S1(n) = G_d(n0) (n/n0)^-w / 2 gives  C = G_d(n0) n0^w Gamma((w+1)/2) / (2 sqrt(pi) Gamma(w/2)).
//
// Discretisation. The field is periodic over an FFT grid nx by ny with spacings dn = 1/(nx dx),
// dm = 1/(ny dy). Each cell (n_i, m_j) carries a cosine of amplitude A = sqrt(2 V) and uniform
// random phase, V being the variance the spectrum assigns to the cell; the real part of the
// complex inverse FFT is the sum of those cosines. Three corrections to the plain "V = S2 dn dm":
//  * Travel direction: only |n| <= band_hi carries power (band limit along travel, which is
//    what the vehicle sees); the low cut is radial, kappa >= band_lo, so it is isotropic.
//  * Lateral aliasing: a grid of spacing dy cannot hold |m| > 1/(2 dy); the line marginal at
//    n needs them (at n = 5 cycle/m, 11 % of S1 lies beyond |m| = 10). As when a continuous
//    surface is sampled, the power at m + k/dy is folded onto m (k = ±1..±3 explicitly).
//  * Row normalisation: for every n_i in the band the cells of row i are scaled so their sum is
//    exactly dn G_d(n_i)/2. This absorbs the folds beyond ±3 and the midpoint error of the
//    coarse lateral grid near kappa -> 0 (where S2 is steep), so the PSD along travel is
//    G_d(n) by construction whatever the lateral grid. Without folds the factors are within
//    0.2 % of 1 at 0.1-0.5 cycle/m (2 % at 2 cycle/m, where the unfolded tail is missing), which
//    confirms the constant C; they depart from 1 only at the lowest frequencies, where the
//    lateral grid is coarse next to the steep kappa^-(w+1). Across lines the PSD then agrees
//    with G_d to about 3 % over 0.5-5 cycle/m (lateral aliasing offsets the band cut in n).
//
// Domain. Along x the FFT period is the next power of two >= max(2 * samples, 2 / (band_lo dx))
// samples, so the lowest band frequency is resolved by >= 2 bins and the output never sees the
// wrap-around. Across, a period as long as along travel (isotropic periodicity) would cost a
// 4096 x 4096 FFT per preset; instead the lateral period is the next power of two >= 4 * lines
// (25.6 m for a 5 m surface). The row normalisation keeps the line PSD exact regardless; the
// lateral coherence of lines up to the surface width apart is kept because the period is at
// least four widths.
//
// Cost: only the first `lines` outputs of each lateral FFT and only the first `samples` of each
// longitudinal FFT are kept, so the longitudinal pass runs on `lines` columns, not ny.
#include "road/surface_generator.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/seed_seq.hpp>
#include <boost/random/uniform_real_distribution.hpp>
#include <unsupported/Eigen/FFT>

#include "util/check.hpp"

namespace ssrfleet::road {

namespace {

constexpr const char* kFunction = "generate_surface";
constexpr int kLateralFolds = 3;
// Grids above this many FFT cells (2^26 complex = 1 GiB) are refused rather than swapped to death.
constexpr Eigen::Index kMaxFftCells = Eigen::Index{1} << 26;

Eigen::Index next_pow2(Eigen::Index n) {
  Eigen::Index p = 1;
  while (p < n) p *= 2;
  return p;
}

Eigen::Index sample_count(double extent_m, double spacing_m) {
  return static_cast<Eigen::Index>(std::lround(extent_m / spacing_m)) + 1;
}

double one_sided_psd(const SurfaceSpec& spec, double n_cpm) {
  return spec.gd_n0_m3 * std::pow(n_cpm / spec.n0_cpm, -spec.waviness);
}

// C of S2 = C kappa^-(w+1) (derivation at the top of this file).
double isotropic_psd_2d_constant(const SurfaceSpec& spec) {
  const double w = spec.waviness;
  return spec.gd_n0_m3 * std::pow(spec.n0_cpm, w) * std::tgamma(0.5 * (w + 1.0)) /
         (2.0 * std::sqrt(std::numbers::pi) * std::tgamma(0.5 * w));
}

}  // namespace

void validate(const SurfaceSpec& spec) {
  check_positive(kFunction, "length_m", spec.length_m);
  check_positive(kFunction, "dx_m", spec.dx_m);
  check_greater_or_equal(kFunction, "length_m", spec.length_m, spec.dx_m);
  check_nonnegative(kFunction, "width_m", spec.width_m);
  check_positive(kFunction, "dy_m", spec.dy_m);
  check_nonnegative(kFunction, "gd_n0_m3", spec.gd_n0_m3);
  check_positive(kFunction, "waviness", spec.waviness);
  check_positive(kFunction, "n0_cpm", spec.n0_cpm);
  check_positive(kFunction, "band_lo_cpm", spec.band_lo_cpm);
  check_in_range(kFunction, "band_hi_cpm", spec.band_hi_cpm, spec.band_lo_cpm,
                 (1.0 + 1e-9) / (2.0 * spec.dx_m));
}

double isotropic_psd_2d(const SurfaceSpec& spec, double kappa_cpm) {
  return isotropic_psd_2d_constant(spec) * std::pow(kappa_cpm, -(spec.waviness + 1.0));
}

Surface generate_surface(const SurfaceSpec& spec, std::uint64_t seed) {
  validate(spec);
  const Eigen::Index samples = sample_count(spec.length_m, spec.dx_m);
  const Eigen::Index lines = sample_count(spec.width_m, spec.dy_m);
  const auto low_cut_samples = static_cast<Eigen::Index>(std::ceil(2.0 / (spec.band_lo_cpm * spec.dx_m)));
  const Eigen::Index nx = next_pow2(std::max(2 * samples, low_cut_samples));
  const Eigen::Index ny = next_pow2(std::max<Eigen::Index>(4 * lines, 16));
  if (nx > kMaxFftCells / ny) {
    throw std::invalid_argument(std::string(kFunction) + ": FFT grid " + std::to_string(nx) + " x " +
                                std::to_string(ny) + " is too large; reduce length, width or band_lo");
  }
  const double dn = 1.0 / (static_cast<double>(nx) * spec.dx_m);
  const double dm = 1.0 / (static_cast<double>(ny) * spec.dy_m);
  const double lateral_period_cpm = 1.0 / spec.dy_m;

  const double s2_constant = isotropic_psd_2d_constant(spec);
  const double half_exponent = -0.5 * (spec.waviness + 1.0);  // S2 = C (kappa^2)^half_exponent
  const double band_lo_squared = spec.band_lo_cpm * spec.band_lo_cpm;

  // Cell amplitudes by |i|, |j| (the spectrum is even in n and in m).
  Eigen::ArrayXXd amplitude = Eigen::ArrayXXd::Zero(nx / 2 + 1, ny / 2 + 1);
  Eigen::ArrayXd row(ny / 2 + 1);
  for (Eigen::Index i = 0; i <= nx / 2; ++i) {
    const double n = static_cast<double>(i) * dn;
    if (n > spec.band_hi_cpm * (1.0 + 1e-12)) break;
    for (Eigen::Index j = 0; j <= ny / 2; ++j) {
      double s = 0.0;
      for (int k = -kLateralFolds; k <= kLateralFolds; ++k) {
        const double m = static_cast<double>(j) * dm + k * lateral_period_cpm;
        const double kappa_squared = n * n + m * m;
        if (kappa_squared >= band_lo_squared) s += s2_constant * std::pow(kappa_squared, half_exponent);
      }
      row(j) = s;
    }
    // Sum over j = -ny/2 .. ny/2-1: the Nyquist column and column 0 once, the others twice.
    const double row_sum = 2.0 * row.sum() - row(0) - row(ny / 2);
    double cell_variance_scale = dn * dm;  // midpoint rule, used below the band
    if (n >= spec.band_lo_cpm * (1.0 - 1e-12) && row_sum > 0.0) {
      cell_variance_scale = dn * 0.5 * one_sided_psd(spec, n) / row_sum;
    }
    amplitude.row(i) = (2.0 * cell_variance_scale * row).sqrt().transpose();
  }

  // One phase per FFT cell, drawn in the order i = 0..nx-1 (outer), j = 0..ny-1 (inner). The
  // 64-bit seed enters through a seed sequence so that its high bits count too.
  boost::random::seed_seq seed_sequence{static_cast<std::uint32_t>(seed & 0xffffffffu),
                                        static_cast<std::uint32_t>(seed >> 32)};
  boost::random::mt19937 engine(seed_sequence);
  boost::random::uniform_real_distribution<double> phase_rad(0.0, 2.0 * std::numbers::pi);

  Eigen::FFT<double> fft;
  fft.SetFlag(Eigen::FFT<double>::Unscaled);
  std::vector<std::complex<double>> spectrum(static_cast<std::size_t>(ny));
  std::vector<std::complex<double>> lateral(static_cast<std::size_t>(ny));
  // Lateral transforms first, keeping only the lines the surface needs.
  Eigen::ArrayXXcd partial(nx, lines);
  for (Eigen::Index i = 0; i < nx; ++i) {
    const Eigen::Index ai = std::min(i, nx - i);
    for (Eigen::Index j = 0; j < ny; ++j) {
      const double a = amplitude(ai, std::min(j, ny - j));
      spectrum[static_cast<std::size_t>(j)] = std::polar(a, phase_rad(engine));
    }
    fft.inv(lateral.data(), spectrum.data(), ny);
    for (Eigen::Index l = 0; l < lines; ++l) partial(i, l) = lateral[static_cast<std::size_t>(l)];
  }

  Surface surface;
  surface.dx_m = spec.dx_m;
  surface.y0_m = 0.0;
  surface.dy_m = spec.dy_m;
  surface.name = "generated(seed=" + std::to_string(seed) + ")";
  surface.height_m.resize(samples, lines);
  std::vector<std::complex<double>> column(static_cast<std::size_t>(nx));
  std::vector<std::complex<double>> profile(static_cast<std::size_t>(nx));
  for (Eigen::Index l = 0; l < lines; ++l) {
    for (Eigen::Index i = 0; i < nx; ++i) column[static_cast<std::size_t>(i)] = partial(i, l);
    fft.inv(profile.data(), column.data(), nx);
    for (Eigen::Index s = 0; s < samples; ++s) surface.height_m(s, l) = profile[static_cast<std::size_t>(s)].real();
  }
  return surface;
}

}  // namespace ssrfleet::road
