// The International Roughness Index (m/km) of a longitudinal profile, by Sayers' (1995)
// algorithm as standardised in ASTM E1926:
//  1. smooth by a moving average of base 0.25 m: k = max(1, round(0.25 / dx)) samples; the
//     smoothed slope is  s_i = (p_{i+k} - p_i) / (k dx),  i = 0 .. n-k-1;
//  2. run the Golden Car (golden_car.hpp) at 80 km/h with that slope held constant over each
//     interval. With the slope as input the states are the derivatives of (z_s, z_s', z_u, z_u')
//     along distance, so state 1 minus state 3 is (z_s' - z_u') / v, and slope held constant
//     means the smoothed profile is read as linear between samples;
//  3. IRI = mean over the steps of |state1 - state3|  (m/m), times 1000 for m/km.
// Initial state (ASTM convention): states 1 and 3 at the average slope of the first 11 m
// (p(11 m) - p(0)) / 11 m, i.e. body and axle start on the line through the first 11 m of road,
// velocities zero. A profile shorter than 11 m uses its whole length.
#pragma once

#include <Eigen/Core>

namespace ssrfleet::road {

// Throws std::invalid_argument if dx <= 0 or the profile is shorter than the smoothing base
// plus one sample (k + 1 samples).
double iri_m_per_km(const Eigen::ArrayXd& profile_m, double dx_m);

// Samples of the 0.25 m smoothing base at spacing dx: max(1, round(0.25 / dx)).
Eigen::Index iri_smoothing_points(double dx_m);

}  // namespace ssrfleet::road
