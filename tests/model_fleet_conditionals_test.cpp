// The fleet model over many trucks from sufficient statistics (model/fleet_conditionals.hpp): the
// sums against the per-truck densities of fleet_model.hpp, and the conditionals' draws against the
// closed-form moments of the distributions they sample.
#include <cmath>
#include <vector>

#include <boost/random/mersenne_twister.hpp>
#include <catch2/catch.hpp>

#include "model/fleet_conditionals.hpp"

using namespace ssrfleet::fleet;

namespace {
LatentSums sums_of(const std::vector<double>& x) {
  LatentSums s;
  for (double v : x) {
    s.n += 1.0;
    s.sum += v;
    s.sum2 += v * v;
  }
  return s;
}
}  // namespace

TEST_CASE("the sums give the per-truck densities of the fleet model added up", "[model]") {
  const std::vector<double> k{4.1e5, 5.3e5, 4.9e5, 6.2e5, 5.05e5};
  const std::vector<double> z{0.4, 1.1, 1.7, 2.9, 3.6};
  const LateralRange road{0.0, 3.75};
  double k_direct = 0.0, z_direct = 0.0;
  for (double v : k) k_direct += log_normal_density(v, 5e5, 5e4);
  for (double v : z) z_direct += log_normal_density(v, 1.5, 0.8) - log_normal_mass(road.lo_m, road.hi_m, 1.5, 0.8);
  CHECK(log_normal_sum(sums_of(k), 5e5, 5e4) == Approx(k_direct).epsilon(1e-12));
  CHECK(log_lateral_sum(sums_of(z), 1.5, 0.8, road) == Approx(z_direct).epsilon(1e-12));
  // 16 residuals of 0.01 each at sigma 0.02: the same as the per-truck form the latent core uses.
  CHECK(log_noise_sum(16.0, 16 * 1e-4, 0.02) == Approx(log_likelihood_from_ssr(16 * 1e-4, 16, 0.02)).epsilon(1e-12));
  CHECK(sums_of(k).squares_about(5e5) == Approx([&] {
          double s = 0.0;
          for (double v : k) s += (v - 5e5) * (v - 5e5);
          return s;
        }()).epsilon(1e-9));
}

TEST_CASE("the conditionals of theta given the latents draw their closed-form distributions", "[model]") {
  // 50 trucks with sample mean 5e5 and sum of squares about it 50 x (4e4)^2.
  LatentSums k{50.0, 50.0 * 5e5, 50.0 * (5e5 * 5e5 + 4e4 * 4e4)};
  boost::random::mt19937_64 engine(7);
  const int draws = 20000;
  // K | k, sigma_k = 5e4 on a wide box: N(5e5, 5e4^2 / 50); mean and sd within 4 Monte Carlo sd.
  double m = 0.0, m2 = 0.0;
  for (int i = 0; i < draws; ++i) {
    const double x = draw_mean_given_latents(engine, k, 5e4, 1e5, 2e6);
    m += x;
    m2 += x * x;
  }
  m /= draws;
  const double sd = std::sqrt(m2 / draws - m * m), sd_true = 5e4 / std::sqrt(50.0);
  CHECK(std::abs(m - 5e5) < 4.0 * sd_true / std::sqrt(draws));
  CHECK(std::abs(sd / sd_true - 1.0) < 4.0 / std::sqrt(2.0 * draws));
  // sigma_k | k, K = 5e5 on a wide box: tau = 1/sigma^2 ~ Gamma(49/2, S/2), S = 50 (4e4)^2, whose
  // mean is 49 / S; the draws' mean of tau within 4 Monte Carlo sd (Gamma sd = sqrt(shape)/rate).
  const double S = k.squares_about(5e5), shape = 24.5, rate = S / 2.0;
  double tau_sum = 0.0;
  for (int i = 0; i < draws; ++i) {
    const double s = draw_sd_given_latents(engine, k, 5e5, 1e3, 5e5);
    tau_sum += 1.0 / (s * s);
  }
  const double tau_mean = tau_sum / draws;
  CHECK(std::abs(tau_mean - shape / rate) < 4.0 * std::sqrt(shape) / rate / std::sqrt(draws));
  // The noise sd over a tempered count of observations: the same Gamma with shape (obs - 1) / 2.
  double noise_tau = 0.0;
  for (int i = 0; i < draws; ++i) {
    const double s = draw_noise_sd_given_ssr(engine, 40.5, 40.5 * 4e-4, 1e-3, 1.0);
    noise_tau += 1.0 / (s * s);
  }
  const double nshape = 0.5 * 39.5, nrate = 0.5 * 40.5 * 4e-4;
  CHECK(std::abs(noise_tau / draws - nshape / nrate) < 4.0 * std::sqrt(nshape) / nrate / std::sqrt(draws));
}
