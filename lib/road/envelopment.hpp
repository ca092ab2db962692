// Tyre envelopment (docs/model.md): a tyre bridges short, sharp features of the road, so the
// input it passes to the axle is a smoothed profile. As in Cebon (1999, "Handbook of Vehicle-Road
// Interaction", §3.3) we model it as a centred moving average of base length L along travel
// (default 0.3 m; 0 = off).
//
// Discrete filter, precisely:
//   half width  h = round(L / (2 dx))  samples,   N = 2h + 1  points (odd, so it is centred),
//   out[i] = mean(in[i-h .. i+h]).
// The centres of the end points span 2 h dx, which equals L whenever L/dx is an even integer
// (L = 0.3 m at dx = 0.05 m: h = 3, N = 7). L < dx gives N = 1, the identity.
// Ends: within h samples of either end the window shrinks symmetrically to the samples that
// exist (half width min(h, i, n-1-i)), so the output stays centred (no phase shift) and the
// first and last samples are passed through unchanged.
#pragma once

#include <Eigen/Core>

#include "road/surface.hpp"

namespace ssrfleet::road {

// N = 2 round(L / (2 dx)) + 1. Throws std::invalid_argument for dx <= 0 or L < 0 (or not finite).
Eigen::Index envelopment_points(double dx_m, double base_length_m);

Eigen::ArrayXd envelop(const Eigen::ArrayXd& profile_m, double dx_m, double base_length_m);

// Every line of the surface filtered along travel; lateral geometry and name are kept.
Surface envelop(const Surface& surface, double base_length_m);

// The transfer function of exactly the interior filter above at spatial frequency n (cycle/m):
// the Dirichlet kernel  H(n) = sin(N pi n dx) / (N sin(pi n dx)),  H(0) = 1. It is real (a
// centred filter has zero phase) and changes sign past its first zero n = 1/(N dx); |H| is the
// amplitude gain.
double envelopment_gain(double n_cpm, double dx_m, double base_length_m);

}  // namespace ssrfleet::road
