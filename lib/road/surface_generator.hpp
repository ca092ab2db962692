// Random isotropic road surfaces (docs/model.md) by the method of Cebon & Newland (1984): a 2-D
// inverse FFT of amplitudes fixed by the spectrum with independent uniform random phases.
//
// Target: along any straight line the one-sided displacement PSD is the power law of
// ISO 8608 / BS 7853,   G_d(n) = G_d(n0) (n / n0)^-w,   band_lo <= n <= band_hi  (cycle/m).
//
// Reproducibility: phases come from boost::random::mt19937 and uniform_real_distribution, which
// give the same sequence on every platform; Boost may change them between Boost versions, so a
// saved reference surface must record the Boost version (built and tested with Boost 1.74).
#pragma once

#include <cstdint>

#include "road/surface.hpp"

namespace ssrfleet::road {

struct SurfaceSpec {
  double length_m = 100.0;     // along travel; samples = round(length / dx) + 1, first at x = 0
  double dx_m = 0.05;          // longitudinal spacing
  double width_m = 5.0;        // across travel; lines = round(width / dy) + 1, first at y = 0
  double dy_m = 0.05;          // lateral spacing
  double gd_n0_m3 = 20e-6;     // G_d(n0), one-sided displacement PSD at n0 (m^3 = m^2/(cycle/m))
  double waviness = 2.0;       // w, the (negative) log-log slope of G_d
  double n0_cpm = 0.1;         // reference spatial frequency (cycle/m)
  double band_lo_cpm = 0.01;   // the PSD is the power law from here ...
  double band_hi_cpm = 10.0;   // ... to here; must not exceed the Nyquist frequency 1/(2 dx)
};

// Throws std::invalid_argument naming the first bad field.
void validate(const SurfaceSpec& spec);

// The isotropic 2-D PSD whose line marginal is the spec's G_d (see the .cpp for the derivation):
//   S2(kappa) = G_d(n0) n0^w Gamma((w+1)/2) / (2 sqrt(pi) Gamma(w/2)) * kappa^-(w+1),
// two-sided, per (cycle/m)^2, kappa = |(n, m)| in cycle/m.
double isotropic_psd_2d(const SurfaceSpec& spec, double kappa_cpm);

// A surface of spec's size with heights in metres; the same (spec, seed) gives the same bits on
// every machine (see the Boost note above). Name "generated(seed=S)".
Surface generate_surface(const SurfaceSpec& spec, std::uint64_t seed);

}  // namespace ssrfleet::road
