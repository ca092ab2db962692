#include "fleet/new_truck_proposals.hpp"

#include "fleet/marginal_target.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

std::optional<model::TableProposal> MarginalTableProposals::proposal(std::size_t truck, const HyperVector& theta) const {
  if (truck >= static_cast<std::size_t>(target_.trucks())) return std::nullopt;
  try {
    return model::TableProposal(target_.tables().view(truck), target_.marginal(), theta);
  } catch (const UsageError&) {
    return std::nullopt;  // θ outside the table's support, or no weight there: the prior instead
  }
}

bool MarginalTableProposals::matches(std::size_t truck, double speed_mps, double sprung_mass_kg) const {
  return truck < static_cast<std::size_t>(target_.trucks()) && target_.absorbed().speed_mps(truck) == speed_mps &&
         target_.absorbed().sprung_mass_kg(truck) == sprung_mass_kg;
}

}  // namespace ssrfleet::fleet
