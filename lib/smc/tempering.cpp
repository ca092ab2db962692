#include "smc/tempering.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "smc/weights.hpp"
#include "util/errors.hpp"

namespace ssrfleet::smc {

void check_loglik(const Eigen::Ref<const Eigen::ArrayXd>& loglik, std::string_view stage_label) {
  for (Eigen::Index i = 0; i < loglik.size(); ++i) {
    const double v = loglik[i];
    if (std::isnan(v) || v == std::numeric_limits<double>::infinity()) {
      std::ostringstream os;
      os << "stage '" << stage_label << "': log-likelihood of particle " << i << " is " << v
         << " (must be finite or -inf)";
      throw NumericalError(os.str());
    }
  }
}

TemperatureStep next_temperature_step(double phi, const Eigen::Ref<const Eigen::ArrayXd>& W,
                                      const Eigen::Ref<const Eigen::ArrayXd>& loglik,
                                      const TemperingOptions& options, std::string_view stage_label) {
  check_loglik(loglik, stage_label);
  const double remaining = 1.0 - phi;
  // ℓ is only defined up to a constant for the CESS; shifting by the max keeps exp in range.
  const double top = (W > 0.0).select(loglik, -std::numeric_limits<double>::infinity()).maxCoeff();
  if (!std::isfinite(top)) {
    std::ostringstream os;
    os << "stage '" << stage_label << "': every weighted particle has zero likelihood (ℓ = -inf)";
    throw NumericalError(os.str());
  }
  const Eigen::ArrayXd shifted = loglik - top;
  // Particles with ℓ = -inf lose their weight at any step > 0, so the relative CESS of an
  // arbitrarily small step tends to the weight share `alive` of the others, not to 1. The target
  // applies to the survivors; otherwise a cloud with more than 1 - target of its weight on
  // impossible states could never take a step.
  const double alive = (loglik > -std::numeric_limits<double>::infinity()).select(W, 0.0).sum() / W.sum();
  const double target = options.cess_target * alive;

  TemperatureStep step;
  step.delta = remaining;
  step.relative_cess = relative_conditional_ess(W, shifted, remaining);
  if (step.relative_cess >= target) return step;

  // Invariant: cess(lo) >= target > cess(hi).
  double lo = 0.0, hi = remaining, cess_lo = 1.0;
  for (step.bisections = 1; step.bisections <= options.max_bisections; ++step.bisections) {
    const double mid = 0.5 * (lo + hi);
    if (!(mid > lo && mid < hi)) break;  // bracket at machine precision
    const double c = relative_conditional_ess(W, shifted, mid);
    if (c >= target) {
      lo = mid;
      cess_lo = c;
    } else {
      hi = mid;
    }
    if (std::abs(cess_lo - target) <= options.tolerance) break;
  }
  step.bisections = std::min(step.bisections, options.max_bisections);
  step.delta = lo;
  step.relative_cess = cess_lo;
  if (step.delta < options.min_step) {
    std::ostringstream os;
    os.precision(17);
    os << "stage '" << stage_label << "': tempering stalled at phi = " << phi << " (step " << step.delta
       << " < " << options.min_step << "); the log-likelihood increment is too peaked for the cloud";
    throw NumericalError(os.str());
  }
  return step;
}

}  // namespace ssrfleet::smc
