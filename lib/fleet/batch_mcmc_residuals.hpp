// The batch MCMC's (batch_mcmc.hpp) view of the data and its one expensive operation: the
// per-truck sums of squared residuals of candidate latents, through batched, threaded
// quarter-car calls. Internal to the sampler (namespace detail); split out to keep
// batch_mcmc.cpp about the chain.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/model_extension.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"
#include "smc/parallel.hpp"

namespace ssrfleet::fleet::detail {

// The observed data in the arrays the sampler works on.
struct Observations {
  Eigen::ArrayXd speed_mps;
  Eigen::ArrayXd sprung_mass_kg;
  Eigen::ArrayXXd impact_factor;  // sensors x trucks
  int trucks = 0;
  int sensors = 0;
};

// Throws DataError when there are no records or a record does not fit the site.
Observations gather(const site::Site& site, const std::vector<records::WimRecord>& records);

// Runs the trucks `which` (indices into obs) with the given (k, kt, z) through the site in
// batches and returns each one's sum of squared residuals against its observations (+inf where
// the integrator returned something non-finite). The batch is split over the threads of
// `parallel` at multiples of the integrator's block (vehicle::batch_block_trucks), so the blocks,
// and with them every truck's bits, are the same whatever the thread count; no random numbers
// are drawn here.
// With a model extension that edits the forward model, every pass goes through the extended
// forward model (extended_forward.hpp, the one the SMC target calls) at the ψ given to evaluate;
// without one (or one that edits only the fleet model) through Site::impact_factors, as always.
class ResidualEvaluator {
 public:
  ResidualEvaluator(const site::Site& site, const Observations& obs, int threads,
                    const ModelExtension* extension = nullptr)
      : site_(site), obs_(obs), parallel_(threads),
        extension_(extension != nullptr && extension->edits_forward() ? extension : nullptr) {}

  // psi: the extension's parameters for every pass (ignored, and may be null, when the forward
  // model is the base one).
  void evaluate(const std::vector<int>& which, const Eigen::ArrayXd& k, const Eigen::ArrayXd& kt,
                const Eigen::ArrayXd& z, const double* psi, Eigen::ArrayXd& ssr_out);

  long long calls() const { return calls_; }
  long long passes() const { return passes_; }

 private:
  const site::Site& site_;
  const Observations& obs_;
  smc::ParallelFor parallel_;
  const ModelExtension* extension_;  // null unless it edits the forward model
  long long calls_ = 0;
  long long passes_ = 0;
};

}  // namespace ssrfleet::fleet::detail
