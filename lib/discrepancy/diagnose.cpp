#include "discrepancy/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <utility>

#include "discrepancy/fit_draws.hpp"
#include "fleet/new_truck_proposals.hpp"
#include "fleet/online_fit.hpp"
#include "fleet/replay.hpp"
#include "model/model_extension.hpp"
#include "model/model_spec.hpp"
#include "util/errors.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::discrepancy {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// A fitted SMC together with the extension it points at (which must outlive it). Each model runs on
// the core `fit` chooses for it (fleet::choose_core; docs/inference.md): the base model,
// second_class, the one-parameter effects inside the dynamics and a gain on the sensor the checks
// point at (candidate_spec) on the marginal core, whose checks draw every truck's latents from
// their exact conditional given (θ, ψ) (marginal_draws.hpp); a profile defect and compositions of
// effects on the latent core, which carries ψ in its particles and re-simulates every kept truck
// when ψ moves.
struct Fitted {
  std::unique_ptr<fleet::ModelExtension> extension;
  std::unique_ptr<fleet::OnlineFit> online;
  ModelFit fit;
};

// The fit of one model. An extension's refit on the latent core takes its new trucks' latents from
// `proposals` (the base fit's tables) when given; a refit on the marginal core needs none (its
// tables integrate them out). No refit runs final sweeps: finish() runs them on the one chosen.
Fitted fit_model(const site::Site& site, const std::vector<records::WimRecord>& records, std::size_t heldout_from,
                 std::unique_ptr<fleet::ModelExtension> extension, const fleet::NewTruckProposals* proposals,
                 const DiagnoseOptions& o) {
  Fitted f;
  f.extension = std::move(extension);
  fleet::OnlineFitOptions so;
  so.core = fleet::choose_core(f.extension.get());
  so.sampler().particles = o.particles;
  so.sampler().threads = o.threads;
  so.sampler().seed = o.seed;
  so.extension = f.extension.get();
  so.latent.proposals = f.extension && so.core == fleet::OnlineFitOptions::Core::kLatent ? proposals : nullptr;
  f.online = fleet::make_online_fit(site, so);
  const std::string label = f.extension ? f.extension->name() : std::string("base model");
  const auto start = Clock::now();
  fleet::ReplayOptions replay;  // the stages, then the same final sweeps as `fit` on that core
  replay.final_sweeps = f.extension ? 0 : o.final_sweeps;
  replay.after_record = [&](std::size_t t, const smc::StageSummary& stage, const fleet::OnlineFit&) {
    if (t >= heldout_from) f.fit.heldout_log_score += stage.log_evidence_increment;
    if (o.progress && ((t + 1) % 25 == 0 || t + 1 == records.size())) {
      *o.progress << "diagnose: " << label << ": truck " << (t + 1) << "/" << records.size() << ", log evidence "
                  << std::fixed << std::setprecision(1) << stage.log_evidence << ", " << seconds_since(start) << " s\n"
                  << std::defaultfloat;
    }
  };
  fleet::replay(*f.online, records, replay);
  f.fit.log_evidence = f.online->sampler().log_evidence();
  f.fit.wall_s = seconds_since(start);
  f.fit.integrator_passes = f.online->integrator_passes();
  // The posterior as fit reports it (on the marginal core, the final sweeps' clouds pooled).
  const auto hyper = fleet::summarise_cloud(f.online->cloud());
  std::copy(hyper.begin(), hyper.end(), f.fit.hyper.begin());
  return f;
}

// The final sweeps of a refit that was chosen (fit_model skipped them), as `fit` runs them.
void finish(Fitted& f, const DiagnoseOptions& o) {
  if (!f.extension) return;
  const int sweeps = o.final_sweeps >= 0 ? o.final_sweeps : f.online->sampler().options().schedule.final_sweeps;
  if (sweeps == 0) return;
  const auto start = Clock::now();
  f.online->rejuvenate(sweeps);
  f.fit.wall_s += seconds_since(start);
  f.fit.integrator_passes = f.online->integrator_passes();
  const auto hyper = fleet::summarise_cloud(f.online->cloud());
  std::copy(hyper.begin(), hyper.end(), f.fit.hyper.begin());
}

std::vector<ParameterEstimate> extension_estimates(const Fitted& f) {
  std::vector<ParameterEstimate> out;
  const auto& params = f.extension->parameters();
  const fleet::PosteriorCloud cloud = f.online->cloud();
  const auto summary = fleet::summarise_weighted(cloud.psi, cloud.weights);
  for (std::size_t j = 0; j < params.size(); ++j) out.push_back({params[j].name, params[j].unit, params[j].null_value, summary[j]});
  return out;
}

CheckReport check(const site::Site& site, const Fitted& f, const DiagnoseOptions& o) {
  CheckOptions co;
  co.alpha = o.alpha;
  co.replicates = o.replicates;
  co.seed = o.seed;
  MarginalDrawOptions d;
  d.draws = o.draws;
  d.seed = o.seed;
  d.threads = o.threads;
  return run_checks(posterior_draws(site, *f.online, d), co);
}

std::vector<std::string> matched_checks(const fleet::ModelExtension& ext, const CheckReport& report) {
  std::vector<std::string> matched;
  for (const auto kind : ext.signature()) {
    for (const auto& c : report.checks) {
      if (c.kind == kind && c.flagged) matched.emplace_back(fleet::check_name(kind));
    }
  }
  return matched;
}

std::string fmt(double v, int precision) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(precision) << v;
  return s.str();
}

}  // namespace

namespace {

// Whether a gap remains, a decision over all the check families at once: a family must fail at
// alpha / K (Bonferroni over the K families), so the verdict and the search for another effect are
// wrong with probability at most alpha for a right model. Each family alone, at alpha, would give
// a right model up to K alpha false alarms (8 % at alpha 0.01 with 8 families): measured on a 100-truck log with
// only a sensor gain hidden, the lateral family alone failed at p = 0.004 after the gain was named.
bool gap_remains(const CheckReport& report, double alpha) {
  const double level = alpha / static_cast<double>(std::max<std::size_t>(1, report.checks.size()));
  return std::any_of(report.checks.begin(), report.checks.end(), [&](const CheckResult& c) { return c.p_value < level; });
}

// The failed checks and what each points at, for an "unexplained" verdict: which family, its
// p-value, and the sensor a per-sensor family singles out.
std::string where_misfit_sits(const CheckReport& report, int sensors, double alpha) {
  const double level = alpha / static_cast<double>(std::max<std::size_t>(1, report.checks.size()));
  std::string s;
  for (const auto& c : report.checks) {
    if (!(c.p_value < level)) continue;
    s += (s.empty() ? "" : "; ") + std::string(fleet::check_name(c.kind)) + " (p = " + fmt(c.p_value, 4);
    if (c.sensor >= 1 && c.sensor <= sensors) s += ", worst at sensor " + std::to_string(c.sensor);
    if (!c.detail.empty()) s += ", " + c.detail;
    s += ")";
  }
  return s;
}

// How a candidate is refitted. An effect with a parameter that names a sensor (sensor_gain) has it
// fixed at the sensor that its own signature's checks point at (the smallest p-value among them),
// and the rest fitted: with one continuous parameter left, the flat-cost core carries it, where the
// sensor free (a discrete choice) needs the latent core, whose cost per truck grows with n. The
// fixed model's evidence p(y | s) bounds the full model's, (1/M) Σ_s p(y | s), from below once
// log M (the sensor's prior mass under the uniform prior) is taken off, and equals it when the data
// single out that sensor: so the bound never favours the effect on a clean log, where the checks'
// worst sensor is chance (the held-out score reads the same trucks the checks did, so its gain is
// slightly optimistic there; the evidence decides first).
struct CandidateSpec {
  std::string text;            // the effect's model spec
  double log_prior_mass = 0.0; // added to the fixed model's log evidence
  std::optional<ParameterEstimate> fixed;
};

// One round of the search: the current model plus each candidate, refitted; the one added (if any).
struct Round {
  std::vector<CandidateResult> candidates;
  std::vector<std::string> alternatives;
  Fitted best;  // online is null when no candidate is supported
  std::string effect;
  CandidateSpec effect_spec;  // how it was fitted (a sensor fixed: "sensor_gain:sensor=5")
  double log_bayes_factor = 0.0, heldout_gain = 0.0;
};

// A fixed parameter as the report names the fitted ones: effect.param in a composition of effects.
ParameterEstimate named_in(ParameterEstimate p, const std::string& effect, bool composed) {
  if (composed) p.name = effect + "." + p.name;
  return p;
}

CandidateSpec candidate_spec(const fleet::ModelExtension& alone, const CheckReport& checks, int sensors) {
  CandidateSpec out{alone.name(), 0.0, std::nullopt};
  const int j = alone.sensor_parameter();
  if (j < 0) return out;
  const auto signature = alone.signature();
  const CheckResult* pointer = nullptr;
  for (const auto& c : checks.checks) {
    if (std::find(signature.begin(), signature.end(), c.kind) == signature.end()) continue;
    if (c.sensor < 1 || c.sensor > sensors) continue;
    if (pointer == nullptr || c.p_value < pointer->p_value) pointer = &c;
  }
  if (pointer == nullptr) return out;
  const auto& p = alone.parameters()[static_cast<std::size_t>(j)];
  out.text = alone.name() + ":" + p.name + "=" + std::to_string(pointer->sensor);
  out.log_prior_mass = -std::log(static_cast<double>(sensors));
  const double s = pointer->sensor;
  out.fixed = ParameterEstimate{p.name, p.unit, p.null_value, {s, 0.0, s, s}};
  return out;
}

Round next_effect(const site::Site& site, const std::vector<records::WimRecord>& records, std::size_t heldout_from,
                  const Fitted& current, const std::string& spec, double spec_log_mass, std::vector<std::string> names,
                  const CheckReport& checks, const fleet::NewTruckProposals* proposals, const DiagnoseOptions& o,
                  const std::function<void(const std::string&)>& say) {
  Round out;
  // The shortlist first (a stable order otherwise), so progress shows the likeliest first.
  std::map<std::string, bool> shortlisted;
  for (const auto& name : names) shortlisted[name] = !matched_checks(*fleet::make_extension(name, site), checks).empty();
  std::stable_sort(names.begin(), names.end(),
                   [&](const std::string& a, const std::string& b) { return shortlisted[a] && !shortlisted[b]; });
  std::vector<Fitted> supported;  // refits that pass both tests, parallel to supported_index
  std::vector<std::size_t> supported_index;
  std::vector<CandidateSpec> supported_specs;
  const std::string against = spec.empty() ? "the base model" : spec;
  for (const auto& name : names) {
    util::throw_if_stopped();
    const auto alone = fleet::make_extension(name, site);
    CandidateResult c;
    c.name = name;
    c.description = alone->description();
    c.matched_checks = matched_checks(*alone, checks);
    if (c.matched_checks.empty() && o.shortlist_only) {
      c.verdict = "not refitted: no failed check in its signature";
      out.candidates.push_back(std::move(c));
      continue;
    }
    const CandidateSpec cs = candidate_spec(*alone, checks, site.sensors());
    const std::string model = spec.empty() ? cs.text : spec + "+" + cs.text;
    say("refitting with " + model);
    Fitted f = fit_model(site, records, heldout_from, fleet::parse_model_spec(model, site).extension, proposals, o);
    f.fit.log_evidence += spec_log_mass + cs.log_prior_mass;  // the full model's, sensors free (candidate_spec)
    c.refitted = true;
    c.fit = f.fit;
    c.log_bayes_factor = f.fit.log_evidence - current.fit.log_evidence;
    c.heldout_gain = f.fit.heldout_log_score - current.fit.heldout_log_score;
    c.parameters = extension_estimates(f);
    if (cs.fixed) c.parameters.insert(c.parameters.begin(), named_in(*cs.fixed, name, !spec.empty()));
    say("  " + model + ": log Bayes factor " + fmt(c.log_bayes_factor, 1) + " against " + against + ", held-out gain " +
        fmt(c.heldout_gain, 1));
    if (c.log_bayes_factor < o.min_log_bayes_factor) {
      c.verdict = "log Bayes factor below " + fmt(o.min_log_bayes_factor, 1);
    } else if (!(c.heldout_gain > 0.0)) {
      c.verdict = "held-out skill not better than " + against + "'s";
    } else {
      supported.push_back(std::move(f));
      supported_index.push_back(out.candidates.size());
      supported_specs.push_back(cs);
    }
    out.candidates.push_back(std::move(c));
  }
  // The choice. Evidence first; but two effects whose log Bayes factors differ by less than the
  // threshold are not told apart by it (the same threshold that separates an effect from the
  // current model), and then held-out skill decides; the others within the threshold are
  // reported as alternatives.
  std::size_t chosen = supported.size();
  double best_bf = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < supported.size(); ++k) best_bf = std::max(best_bf, out.candidates[supported_index[k]].log_bayes_factor);
  for (std::size_t k = 0; k < supported.size(); ++k) {
    const auto& c = out.candidates[supported_index[k]];
    if (c.log_bayes_factor < best_bf - o.min_log_bayes_factor) continue;
    if (chosen == supported.size() || c.heldout_gain > out.candidates[supported_index[chosen]].heldout_gain) chosen = k;
  }
  if (chosen == supported.size()) return out;
  auto& pick = out.candidates[supported_index[chosen]];
  out.effect = pick.name;
  out.effect_spec = supported_specs[chosen];
  out.log_bayes_factor = pick.log_bayes_factor;
  out.heldout_gain = pick.heldout_gain;
  out.best = std::move(supported[chosen]);
  say("final sweeps of " + (spec.empty() ? out.effect_spec.text : spec + "+" + out.effect_spec.text));
  finish(out.best, o);
  for (std::size_t k = 0; k < supported.size(); ++k) {
    auto& c = out.candidates[supported_index[k]];
    if (k == chosen) {
      c.verdict = "chosen";
    } else if (c.log_bayes_factor >= best_bf - o.min_log_bayes_factor) {
      c.verdict = "alternative: evidence within " + fmt(o.min_log_bayes_factor, 1) + " of " + out.effect +
                  ", held-out skill lower";
      out.alternatives.push_back(c.name);
    } else {
      c.verdict = "supported, but less than " + out.effect;
    }
  }
  return out;
}

}  // namespace

void DiagnoseOptions::validate() const {
  if (particles < 2) throw UsageError("diagnose: particles must be at least 2");
  if (threads < 1) throw UsageError("diagnose: threads must be at least 1");
  if (!(alpha > 0.0 && alpha < 1.0)) throw UsageError("diagnose: alpha must be in (0, 1)");
  if (!std::isfinite(min_log_bayes_factor)) throw UsageError("diagnose: the log Bayes factor threshold must be finite");
  if (!(holdout_fraction > 0.0 && holdout_fraction < 1.0)) throw UsageError("diagnose: holdout fraction must be in (0, 1)");
  if (draws < 10) throw UsageError("diagnose: draws must be at least 10");
  if (replicates < 100) throw UsageError("diagnose: replicates must be at least 100");
  if (final_sweeps < -1) throw UsageError("diagnose: final sweeps must be >= 0 (or -1 for the default)");
  if (max_effects < 1) throw UsageError("diagnose: max effects must be at least 1");
}

DiagnoseResult diagnose(const site::Site& site, const std::vector<records::WimRecord>& records, const DiagnoseOptions& o) {
  o.validate();
  const auto start = Clock::now();
  const std::size_t n = records.size();
  if (n < 8) throw UsageError("diagnose: needs at least 8 trucks; the log has " + std::to_string(n));
  DiagnoseResult r;
  r.trucks = static_cast<int>(n);
  r.heldout_trucks = std::max(1, static_cast<int>(std::lround(o.holdout_fraction * static_cast<double>(n))));
  r.sensors = site.sensors();
  r.sensor_positions_m = site.sensor_positions_m();
  r.alpha = o.alpha;
  r.min_log_bayes_factor = o.min_log_bayes_factor;
  const std::size_t heldout_from = n - static_cast<std::size_t>(r.heldout_trucks);
  const auto say = [&](const std::string& line) {
    if (o.progress) *o.progress << "diagnose: " << line << "\n";
  };

  // Which extensions are candidates at all (checked before the long base fit).
  std::vector<std::string> names = o.candidates.empty() ? fleet::extension_names() : o.candidates;
  for (const auto& name : names) fleet::make_extension(name, site);  // UsageError on an unknown name

  say("fitting the base model (" + std::to_string(o.particles) + " particles)");
  const Fitted base = fit_model(site, records, heldout_from, nullptr, nullptr, o);
  // The base fit's tables propose every refit's new trucks (it outlives them all).
  const std::unique_ptr<fleet::NewTruckProposals> tables = base.online->table_proposals();
  const fleet::NewTruckProposals* proposals = o.refit_from_tables ? tables.get() : nullptr;
  r.base = base.fit;
  say("posterior predictive checks on the base model");
  r.checks_before = check(site, base, o);
  for (const auto& c : r.checks_before.checks) {
    say("  " + std::string(fleet::check_name(c.kind)) + ": p = " + fmt(c.p_value, 4) + (c.flagged ? "  FAILED" : "") +
        (c.detail.empty() ? "" : " (" + c.detail + ")"));
  }

  // Effect by effect: each round refits the current model plus each remaining candidate, adds the
  // one the evidence and held-out skill support, and checks again. The search goes on after the
  // checks pass: a second effect can hide behind the first (a sensor gain's fit absorbs the
  // gap a tyre damping leaves, so the checks pass while the evidence for the damping on top of the
  // gain is still strong), and only the evidence and held-out skill of each remaining effect on top
  // of the chosen model can tell. It ends when no candidate is supported, or at max_effects.
  std::string spec;  // the current model's effects ("" = base)
  double spec_log_mass = 0.0;  // the log prior mass of the sensors fixed in spec (candidate_spec)
  std::vector<std::pair<std::string, ParameterEstimate>> spec_fixed;  // and those sensors by effect, for the report
  Fitted extended;   // the model with the effects named so far (online null: the base model)
  const auto current_fit = [&]() -> const Fitted& { return extended.online ? extended : base; };
  CheckReport current_checks = r.checks_before;
  for (int round = 0; round < o.max_effects; ++round) {
    std::vector<std::string> remaining;
    for (const auto& name : names) {
      if (std::find(r.effects.begin(), r.effects.end(), name) == r.effects.end()) remaining.push_back(name);
    }
    if (remaining.empty()) break;
    if (round > 0) {
      say(gap_remains(current_checks, o.alpha) ? "a gap remains with " + spec + ": looking for another effect"
                                               : "the checks pass with " + spec +
                                                     ": weighing each remaining effect on top of it");
    }
    const auto round_start = Clock::now();
    Round next = next_effect(site, records, heldout_from, current_fit(), spec, spec_log_mass, remaining, current_checks,
                             proposals, o, say);
    if (round == 0) {
      r.candidates = next.candidates;
      r.alternatives = next.alternatives;
    }
    DiagnoseStep step;
    step.candidates = std::move(next.candidates);
    if (!next.best.online) {
      step.wall_s = seconds_since(round_start);
      r.steps.push_back(std::move(step));
      break;
    }
    spec = spec.empty() ? next.effect_spec.text : spec + "+" + next.effect_spec.text;
    spec_log_mass += next.effect_spec.log_prior_mass;
    if (next.effect_spec.fixed) spec_fixed.emplace_back(next.effect, *next.effect_spec.fixed);
    r.effects.push_back(next.effect);
    extended = std::move(next.best);
    say("posterior predictive checks with " + spec);
    current_checks = check(site, extended, o);
    step.effect = next.effect;
    step.model = spec;
    step.log_bayes_factor = next.log_bayes_factor;
    step.heldout_gain = next.heldout_gain;
    step.checks = current_checks;
    step.wall_s = seconds_since(round_start);
    r.steps.push_back(std::move(step));
  }

  const bool open_gap = gap_remains(current_checks, o.alpha);
  r.verdict = open_gap ? "unexplained" : (r.effects.empty() ? "none" : "explained");
  r.effect = r.effects.empty() ? r.verdict : r.effects.front();
  r.model = spec.empty() ? "base" : spec;
  r.checks_after = current_checks;
  const Fitted& current = current_fit();
  r.chosen = current.fit;
  r.posterior = current.online->cloud();
  if (current.extension) {
    r.description = current.extension->description();
    for (const auto& [effect, p] : spec_fixed) r.parameters.push_back(named_in(p, effect, r.effects.size() > 1));
    const auto fitted = extension_estimates(current);
    r.parameters.insert(r.parameters.end(), fitted.begin(), fitted.end());
    r.log_bayes_factor = current.fit.log_evidence - r.base.log_evidence;
    r.heldout_gain = current.fit.heldout_log_score - r.base.heldout_log_score;
  }
  if (open_gap) {
    r.description = (r.effects.empty() ? std::string("checks failed, and no extension in the catalogue is decisively "
                                                     "better than the base model")
                                       : "checks still fail after " + spec + ", and no further extension in the "
                                                                              "catalogue is decisively better") +
                    ": the misfit is unexplained; where it sits: " + where_misfit_sits(current_checks, r.sensors, o.alpha);
  } else if (r.effects.empty()) {
    r.description = "every posterior predictive check passed and no extension in the catalogue is decisively better than "
                    "the base model: nothing is missing that these data can reveal";
  }
  r.wall_s = seconds_since(start);
  return r;
}

}  // namespace ssrfleet::discrepancy
