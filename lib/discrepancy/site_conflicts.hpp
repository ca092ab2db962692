// Which site's fleet differs from the others'? A fit of many sites shares one
// fleet; a site whose trucks come from another fleet (another operator's vehicles, another axle
// mix) pulls the shared posterior and should be named, not averaged in.
//
// The check is cross-validatory, site by site (a conflict p-value, Presanis et al. 2013,
// "Conflict diagnostics in directed acyclic graphs, with applications in Bayesian evidence
// synthesis", Statistical Science 28(3); Marshall & Spiegelhalter 2007): the fleet's posterior from
// site s alone and from every other site without s are two independent estimates of one fleet
// when the model holds. On the fleet's four stiffness hyperparameters φ = (K, log σ_k, K_t,
// log σ_kt) (log scale: the sds' posteriors are skewed), their difference δ has covariance
// Σ_s + Σ_-s (the two clouds' weighted covariances), and
//   D² = δᵀ (Σ_s + Σ_-s)⁻¹ δ  ~  χ²_4,   p = P(χ²_4 ≥ D²) = e^{-D²/2} (1 + D²/2)
// under a normal approximation to each posterior. A site is flagged when p < alpha / S (Bonferroni
// over the S sites: the chance that any site of a sound network is flagged stays near alpha).
// The lateral hyperparameters (Z, σ_z) and the noise σ_IF are reported, not tested: a lane or a
// sensor array may differ between sites while the fleet does not.
//
// One odd site also pulls every "other sites" posterior it is part of, so a sound site's check can
// fail beside it (swamping). So the check runs in rounds: each round checks every site still in;
// if the largest D² is flagged, that site is named, taken out, and the rest checked again, until no
// site is flagged. Two sites cannot say which of them differs: when the last two (or the only two)
// conflict, both are marked undecided and neither is named. A site keeps the figures of the last
// round it was checked in.
//
// Cost: 2S fits per round on the marginal core, of n_s and N - n_s trucks; rounds = flagged + 1.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "fleet/online_fit.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::discrepancy {

struct SiteConflictOptions {
  fleet::OnlineFitOptions fit;  // the marginal core's; each fit's seed is derived from fit's seed
  double alpha = 0.01;          // family-wise: a site is flagged at p < alpha / S
  std::function<void(const std::string&)> progress;  // a line per fit (may be empty)
};

struct SiteConflict {
  std::size_t site = 0;
  long trucks = 0;
  // Posterior mean and sd of the 7 hyperparameters (fleet_model.hpp order): the site alone, and
  // every other site without it.
  std::array<double, 7> alone_mean{}, alone_sd{}, rest_mean{}, rest_sd{};
  double distance2 = 0.0;  // D² on the 4 stiffness hyperparameters
  double p_value = 1.0;
  bool flagged = false;
  // The last two sites left conflict (p below the threshold), but two cannot say which differs: both
  // are marked, neither flagged (a check of two sites ends so too).
  bool undecided = false;
  int round = 1;            // the round these figures come from (flagged: the round it was named in)
  std::size_t compared_with = 0;  // how many other sites its "other sites" fit held
};

// One entry per site, in order. `per_site[s]`: site s's records (their `site` field is ignored).
// UsageError for fewer than two sites or a site without records.
std::vector<SiteConflict> check_site_conflicts(const std::vector<const site::Site*>& sites,
                                               const std::vector<std::vector<records::WimRecord>>& per_site,
                                               const SiteConflictOptions& options);

// P(χ²_4 ≥ x): the tail of the check's reference distribution.
double chi2_4_tail(double x);

}  // namespace ssrfleet::discrepancy
