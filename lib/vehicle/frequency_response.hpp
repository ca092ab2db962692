// The analytic steady-state response of the impact factor to a sinusoidal profile, from the
// transfer function of the quarter car's state space (quarter_car.hpp). For a profile
// r = Re(a e^{i w t}) (so r' = Re(i w a e^{i w t})), the steady state is x = Re(X a e^{i w t}) with
//   (i w I - A) X = B U,   U = (1, i w),
// and IF - 1 = Re(H(w) a e^{i w t}), H(w) = (k_t (1 - X_y1) + c_t (i w - X_y1')) / ((m1 + m2) g).
// For r = a sin(2 pi x / lambda) at speed v (w = 2 pi v / lambda): IF - 1 = a |H| sin(w t + arg H).
#pragma once

#include <complex>

#include "vehicle/quarter_car.hpp"

namespace ssrfleet::vehicle {

// H(w): complex IF - 1 per metre of profile amplitude at angular frequency w (rad/s, >= 0).
std::complex<double> impact_factor_response(const QuarterCar& car, double angular_frequency_rps);

// The same at the temporal frequency of wavelength lambda travelled at speed v: w = 2 pi v / lambda.
std::complex<double> impact_factor_response_wavelength(const QuarterCar& car, double speed_mps,
                                                       double wavelength_m);

}  // namespace ssrfleet::vehicle
