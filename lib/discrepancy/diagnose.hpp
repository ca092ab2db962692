// The model-discrepancy workflow (docs/diagnosis.md): fit the base model, run the posterior
// predictive checks, shortlist the catalogue's extensions whose signature matches the failed
// checks, refit with each by the same SMC, choose by log-evidence (the Bayes factor against the
// base model) confirmed by held-out predictive skill, and measure the gap again with the chosen
// effect in the model. Among the supported candidates, those within the threshold of the largest
// log Bayes factor are not told apart by evidence, and the best held-out skill among them is chosen.
// The search goes on from the model so far (a composed model, model_spec.hpp), one effect a round,
// while the evidence and held-out skill support another effect on top of it (whether or not a
// check still fails: a first effect can hide a second from the checks), up to max_effects. The verdict: "none" (no check fails, no
// effect supported), "explained" (effects named, no check fails with them) or "unexplained" (a
// check still fails, with the failed checks and where they point in the description).
//
// By default every extension is refitted, the shortlisted ones first: the checks look at
// residuals after each truck's own (k, k_t, z) have been fitted, and those latents absorb much
// of a vehicle-wide effect. Tyre damping of 2 kN s/m on 100 trucks, for one, passes every check
// while its log Bayes factor is above 30. `shortlist_only` refits only the shortlist (faster,
// blind to such effects).
//
// Held-out skill: the SMC absorbs trucks in order, so the log-evidence increment of truck i is
// log p(y_i | y_1..i-1), a prediction of data not yet fitted. The held-out score is the sum over
// the last `holdout_fraction` of the trucks: how well each model, fitted on the trucks before,
// predicts the ones after.
#pragma once

#include <cstdint>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "discrepancy/posterior_checks.hpp"
#include "fleet/posterior_summary.hpp"
#include "model/fleet_model.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::discrepancy {

struct DiagnoseOptions {
  int particles = 512;
  int threads = 1;
  std::uint64_t seed = 1;
  // Sweeps at phi = 1 after the last truck of the fit each round ends with (the effect chosen), as
  // `fit` runs them; -1: the latent core's schedule (50). The checks then read a posterior of the
  // same quality as `fit --core latent`. The candidates that are not chosen skip them: their
  // evidence and held-out score come from the stages alone.
  int final_sweeps = -1;
  // Each candidate's refit draws a new truck's latents from the base fit's table of that truck
  // (fleet/new_truck_proposals.hpp) and moves the older trucks and ψ only after resampling; false:
  // from the fleet prior, tempered in with moves after every step (the cost grows like N²).
  bool refit_from_tables = true;
  double alpha = 0.01;              // a check fails when its predictive p-value is below this
  double min_log_bayes_factor = 3.0;  // log BF an effect needs (3: "strong", Kass & Raftery 1995)
  double holdout_fraction = 0.25;   // the last quarter of the trucks scores held-out skill
  int draws = 200;                  // posterior draws behind the checks
  int replicates = 4000;            // replicated data sets per check
  std::vector<std::string> candidates;  // empty: the whole catalogue
  bool shortlist_only = false;       // refit only candidates with a failed check in their signature
  int max_effects = 3;               // effects added at most, one per round
  std::ostream* progress = nullptr;

  void validate() const;  // UsageError naming the option
};

struct ParameterEstimate {
  std::string name, unit;
  double null_value = 0.0;          // the base model's value
  fleet::ParameterSummary posterior;
};

struct ModelFit {
  double log_evidence = 0.0;
  double heldout_log_score = 0.0;
  double wall_s = 0.0;
  long long integrator_passes = 0;
  std::array<fleet::ParameterSummary, fleet::kHyperCount> hyper{};
};

struct CandidateResult {
  std::string name, description;
  std::vector<std::string> matched_checks;  // failed checks in its signature
  bool refitted = false;
  ModelFit fit;                                 // if refitted
  double log_bayes_factor = std::numeric_limits<double>::quiet_NaN();  // vs the base model
  double heldout_gain = std::numeric_limits<double>::quiet_NaN();      // held-out score minus the base's
  std::vector<ParameterEstimate> parameters;
  std::string verdict;  // why it was chosen or not
};

// One round of the search for effects: the effect added (none: the round ended the search), the
// model after it, its evidence and skill against the model before, the checks with it.
struct DiagnoseStep {
  std::string effect;  // "" when no candidate was supported
  std::string model;   // the effects so far, e.g. "sensor_gain+unsprung_mass"
  double log_bayes_factor = 0.0, heldout_gain = 0.0;
  CheckReport checks;  // with `model` (empty when no effect was added)
  std::vector<CandidateResult> candidates;
  double wall_s = 0.0;  // the round: its refits, the chosen one's final sweeps, its checks
};

struct DiagnoseResult {
  // The first effect named, or "none" (no check fails and no effect is supported) or
  // "unexplained" (checks fail and no catalogue effect is supported).
  std::string effect = "none";
  std::vector<std::string> effects;  // every effect named, in order
  // "none", "explained" (effects named and no check fails with them) or "unexplained" (a check
  // still fails after the last effect added, or with none).
  std::string verdict = "none";
  std::string model = "base";              // the model diagnose ends with
  std::vector<DiagnoseStep> steps;
  std::string description;                 // of the effect, or why none
  std::vector<ParameterEstimate> parameters;  // of the final model's effects (effect.param with several)
  // Other supported effects whose evidence is within the threshold of the chosen one's: these
  // data cannot tell them apart by evidence (held-out skill chose).
  std::vector<std::string> alternatives;
  double log_bayes_factor = 0.0;
  double heldout_gain = 0.0;
  int trucks = 0, heldout_trucks = 0, sensors = 0;
  std::vector<double> sensor_positions_m;
  ModelFit base;
  CheckReport checks_before, checks_after;  // after: with every effect named (= before when none)
  ModelFit chosen;                          // the final model's fit (= base when none)
  std::vector<CandidateResult> candidates;  // the first round's
  double alpha = 0.01, min_log_bayes_factor = 3.0;
  double wall_s = 0.0;
  // The posterior diagnose ends with: the chosen effect's model (its "model" names the effect),
  // or the base model's; a posterior file of it is ready for predict.
  fleet::PosteriorCloud posterior;
};

// records: the WIM log, in arrival order; its sensor count must be the site's (DataError).
DiagnoseResult diagnose(const site::Site& site, const std::vector<records::WimRecord>& records, const DiagnoseOptions& options);

}  // namespace ssrfleet::discrepancy
