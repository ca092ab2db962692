// Adaptive choice of the next temperature (Jasra et al. 2011; Zhou, Johansen & Aston 2016): the
// step δ = φ' - φ is the largest one whose relative conditional ESS does not fall below a target,
// found by bisection (the CESS is non-increasing in δ).
#pragma once

#include <string_view>

#include <Eigen/Core>

namespace ssrfleet::smc {

struct TemperingOptions {
  // Target relative CESS per step, in (0, 1). 0.9 lies in the range Zhou, Johansen & Aston
  // (2016) found to give a low-variance evidence estimate: each step costs about 10 % of the
  // sample's information, so the MCMC moves after every step keep the cloud close to the
  // current target. Lower targets take fewer, larger steps (cheaper, noisier log Z); the
  // number of steps grows roughly like 1 / -log(target).
  double cess_target = 0.9;
  // Bisection stops when |relative CESS - target| <= tolerance ...
  double tolerance = 1e-6;
  // ... or after this many halvings (the bracket is then (1 - φ) 2^-max_bisections wide).
  int max_bisections = 100;
  // A step below this with φ < 1 means tempering has stalled: NumericalError.
  double min_step = 1e-12;
};

struct TemperatureStep {
  double delta = 0.0;          // φ' - φ
  double relative_cess = 1.0;  // CESS(δ) / P achieved
  int bisections = 0;          // iterations used (0 when the whole way to φ = 1 was taken)
};

// Throws NumericalError naming the first particle whose ℓ is NaN or +inf, and the stage label
// (the caller's context, e.g. "truck 17"): "stage 'truck 17': log-likelihood of particle 3 is nan".
void check_loglik(const Eigen::Ref<const Eigen::ArrayXd>& loglik, std::string_view stage_label);

// The next step from φ (in [0, 1)) given normalised weights W and the increment ℓ: δ = 1 - φ if
// that keeps the relative CESS >= target, else the bisection root. NumericalError (naming the
// stage) if ℓ has a NaN, if no weighted particle has finite ℓ, or if δ < min_step.
TemperatureStep next_temperature_step(double phi, const Eigen::Ref<const Eigen::ArrayXd>& W,
                                      const Eigen::Ref<const Eigen::ArrayXd>& loglik,
                                      const TemperingOptions& options, std::string_view stage_label);

}  // namespace ssrfleet::smc
