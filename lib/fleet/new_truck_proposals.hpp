// Where the latent core (FleetTarget) can draw a new truck's latents from when it has something
// better than the fleet prior p(x | θ): the truck's table from a marginal fit of the same log
// (model/table_proposal.hpp), which is close to the truck's exact conditional p(x | y, θ) under the
// base model.
//
// Why: drawn from p(x | θ), a new truck's 16 impact factors are far more precise than its prior,
// so every stage of the latent core tempers its likelihood in over several steps, each of which
// resamples and then re-sweeps every older truck: O(n) integrator passes per particle per truck,
// O(N²) per fit. Drawn from a proposal near p(x | y, θ), the stage's weights are close to the
// truck's marginal likelihood ℓ_n(θ), as in the marginal core's IBIS: one reweighting, and the
// older trucks and ψ are moved only when the weights have degenerated enough to resample.
// `diagnose` refits every candidate effect this way on its base fit's tables.
#pragma once

#include <cstddef>
#include <optional>

#include "model/fleet_model.hpp"
#include "model/table_proposal.hpp"

namespace ssrfleet::fleet {

class MarginalTarget;

class NewTruckProposals {
 public:
  virtual ~NewTruckProposals() = default;
  // The proposal for the truck that arrived `truck`-th (0-based) at θ; nullopt where there is
  // none (no such truck, or a θ at which its table carries no weight): the latent core then draws
  // that particle's latents from p(x | θ).
  virtual std::optional<model::TableProposal> proposal(std::size_t truck, const HyperVector& theta) const = 0;
  // Whether the truck that arrived `truck`-th has this speed and sprung mass: the latent core
  // checks that it absorbs the same log in the same order as the tables were built for.
  virtual bool matches(std::size_t truck, double speed_mps, double sprung_mass_kg) const = 0;
};

// The tables of a marginal fit (MarginalTarget) that absorbed the same records in the same order.
// Not owned; the target must outlive this.
class MarginalTableProposals final : public NewTruckProposals {
 public:
  explicit MarginalTableProposals(const MarginalTarget& target) : target_(target) {}
  std::optional<model::TableProposal> proposal(std::size_t truck, const HyperVector& theta) const override;
  bool matches(std::size_t truck, double speed_mps, double sprung_mass_kg) const override;

 private:
  const MarginalTarget& target_;
};

}  // namespace ssrfleet::fleet
