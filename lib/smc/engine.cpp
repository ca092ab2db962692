#include "smc/engine.hpp"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <thread>
#include <utility>

#include "smc/weights.hpp"
#include "util/errors.hpp"
#include "util/option_rules.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::smc {

namespace {

// Purposes of the engine's streams (first key below the root).
enum StreamPurpose : std::uint64_t { kModel = 1, kResample = 2, kMove = 3, kStandaloneMove = 4 };

}  // namespace

int TemperedSampler::Options::default_threads() {
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : static_cast<int>(n);
}

bool TemperedSampler::Options::IsValid(std::string* error) const {
  util::OptionRules rules("TemperedSampler::Options", error);
  rules.require(particles >= 2, "particles", particles, ">= 2");
  // An absurd count fails here, before a cloud of it is allocated (docs/site-data.md).
  rules.require(particles <= kMaxParticles, "particles", particles, "<= 10000000");
  rules.require(threads >= 1, "threads", threads, ">= 1");
  rules.require(ess_rmin >= 0.0 && ess_rmin <= 1.0, "ess_rmin", ess_rmin, "in [0, 1]");
  rules.require(tempering.cess_target > 0.0 && tempering.cess_target < 1.0, "tempering.cess_target",
                tempering.cess_target, "in (0, 1)");
  rules.require(tempering.tolerance > 0.0 && tempering.tolerance < 1.0, "tempering.tolerance", tempering.tolerance,
                "in (0, 1)");
  rules.require(tempering.max_bisections >= 1, "tempering.max_bisections", tempering.max_bisections, ">= 1");
  rules.require(tempering.min_step > 0.0 && tempering.min_step < 1.0, "tempering.min_step", tempering.min_step,
                "in (0, 1)");
  rules.require(mh.scale > 0.0 && std::isfinite(mh.scale), "mh.scale", mh.scale, "positive");
  rules.require(mh.independence_df > 0.0, "mh.independence_df", mh.independence_df, "positive");
  rules.require(mh.independence_inflation > 0.0 && std::isfinite(mh.independence_inflation),
                "mh.independence_inflation", mh.independence_inflation, "positive");
  std::string schedule_error;
  rules.nested(schedule.IsValid(&schedule_error), schedule_error);
  return rules.passed();
}

TemperedSampler::TemperedSampler(Options options)
    : options_(std::move(options)), parallel_(options_.threads >= 1 ? options_.threads : 1), root_(options_.seed) {
  std::string error;
  if (!options_.IsValid(&error)) throw UsageError(error);
  log_weights_ = Eigen::ArrayXd::Constant(options_.particles, -std::log(static_cast<double>(options_.particles)));
}

RngFactory TemperedSampler::model_rngs() const {
  return root_.child(kModel, static_cast<std::uint64_t>(stages_run_));
}

Eigen::ArrayXd TemperedSampler::weights() const { return log_weights_.exp(); }

void TemperedSampler::restore(const State& state) {
  if (state.log_weights.size() != options_.particles || state.stages_run < 0) {
    throw UsageError("TemperedSampler::restore: the saved state has " + std::to_string(state.log_weights.size()) +
                     " particles but options.particles is " + std::to_string(options_.particles));
  }
  stages_run_ = state.stages_run;
  moves_run_ = state.moves_run;
  log_evidence_ = state.log_evidence;
  log_weights_ = state.log_weights;
  history_.clear();
}

double TemperedSampler::ess() const { return effective_sample_size(weights()); }

StageSummary TemperedSampler::run_stage(TemperedModel& model, std::string_view label, bool counts_as_evidence) {
  const auto started = std::chrono::steady_clock::now();
  const Eigen::Index P = options_.particles;
  if (model.particles() != P) {
    std::ostringstream os;
    os << "TemperedSampler::run_stage: stage '" << label << "': the model has " << model.particles()
       << " particles but options.particles is " << P;
    throw UsageError(os.str());
  }
  StageSummary summary;
  summary.stage = stages_run_;
  summary.label = std::string(label);
  const auto stage_key = static_cast<std::uint64_t>(stages_run_);

  Eigen::ArrayXd log_base(P), loglik(P);
  model.log_density(log_base, loglik, parallel_);
  check_loglik(loglik, label);
  // A particle may sit outside the new stage's support only if it is already dead (zero weight
  // carried over from an earlier stage that was not followed by resampling); it stays dead.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < P; ++i) {
    const bool dead = log_weights_[i] == -kInf;
    if (std::isnan(log_base[i]) || log_base[i] == kInf || (log_base[i] == -kInf && !dead)) {
      std::ostringstream os;
      os << "stage '" << label << "': log base density of particle " << i << " is " << log_base[i]
         << " (a particle outside the support, or a NaN)";
      throw NumericalError(os.str());
    }
  }

  std::vector<int> runs_in_stage;  // per schedule entry (MoveSchedule::max_runs_per_stage)
  double phi = 0.0;
  for (int step = 0; phi < 1.0; ++step) {
    util::throw_if_stopped();
    StepInfo info;
    info.step = step;
    const Eigen::ArrayXd W = log_weights_.exp();

    // 1. next temperature, 2. reweight (log Z increment with the weights before the step).
    const TemperatureStep ts = next_temperature_step(phi, W, loglik, options_.tempering, label);
    const bool last = ts.delta == 1.0 - phi;
    info.delta_phi = ts.delta;
    info.relative_cess = ts.relative_cess;
    info.bisections = ts.bisections;
    info.log_evidence_increment = log_mean_weight_increment(W, loglik, ts.delta);
    phi = last ? 1.0 : phi + ts.delta;
    info.phi = phi;
    Eigen::ArrayXd logw = log_weights_ + log_increment(loglik, ts.delta);
    log_weights_ = logw - log_sum_exp(logw);
    summary.log_evidence_increment += info.log_evidence_increment;
    Eigen::ArrayXd Wnew = log_weights_.exp();
    info.ess = effective_sample_size(Wnew);

    // 3. resample if degenerate.
    if (info.ess < options_.ess_rmin * static_cast<double>(P)) {
      Rng rng = root_.child(kResample, stage_key).stream(static_cast<std::uint64_t>(step));
      const std::vector<Eigen::Index> ancestors = resample(options_.resampling, Wnew, P, rng);
      model.resample(ancestors);
      Eigen::ArrayXd b(P), l(P);
      for (Eigen::Index i = 0; i < P; ++i) {
        b[i] = log_base[ancestors[static_cast<std::size_t>(i)]];
        l[i] = loglik[ancestors[static_cast<std::size_t>(i)]];
      }
      log_base.swap(b);
      loglik.swap(l);
      log_weights_.setConstant(-std::log(static_cast<double>(P)));
      Wnew.setConstant(1.0 / static_cast<double>(P));
      info.resampled = true;
    }

    // 4. move at the new temperature (IBIS: only once resampling has duplicated particles).
    const MoveSchedule& schedule = options_.schedule;
    if (schedule.trigger == MoveSchedule::Trigger::kEveryStep || info.resampled || model.moves_every_step()) {
      info.mh = run_sweeps(model, phi, Wnew, log_base, loglik,
                           root_.child(kMove, stage_key, static_cast<std::uint64_t>(step)), parallel_, options_.mh,
                           schedule, schedule.min_sweeps, schedule.max_sweeps, runs_in_stage, label);
      check_loglik(loglik, label);  // model moves may have written the cache
    }

    summary.steps.push_back(info);
    summary.log_evidence = log_evidence_ + (counts_as_evidence ? summary.log_evidence_increment : 0.0);
    summary.final_ess = effective_sample_size(Wnew);
    summary.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (options_.progress) options_.progress(summary, summary.steps.back());
  }

  if (counts_as_evidence) log_evidence_ += summary.log_evidence_increment;
  summary.log_evidence = log_evidence_;
  ++stages_run_;
  summary.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  // The history is a report of recent stages; an unbounded stream must not grow it forever.
  if (history_.size() >= kHistoryLimit) history_.erase(history_.begin());
  history_.push_back(summary);
  return summary;
}

MhSummary TemperedSampler::move(TemperedModel& model, std::string_view label, int sweeps,
                                 const SweepObserver& after_sweep) {
  const Eigen::Index P = options_.particles;
  if (model.particles() != P) throw UsageError("TemperedSampler::move: the model's particle count differs from options.particles");
  if (sweeps < 1) throw UsageError("TemperedSampler::move: sweeps must be >= 1");
  Eigen::ArrayXd log_base(P), loglik(P);
  model.log_density(log_base, loglik, parallel_);
  check_loglik(loglik, label);
  const Eigen::ArrayXd W = log_weights_.exp();
  std::vector<int> runs;  // a call of its own: per-stage limits count from zero
  const MhSummary s = run_sweeps(model, 1.0, W, log_base, loglik,
                                 root_.child(kStandaloneMove, static_cast<std::uint64_t>(stages_run_),
                                             static_cast<std::uint64_t>(moves_run_)),
                                 parallel_, options_.mh, options_.schedule, sweeps, sweeps, runs, label, after_sweep);
  ++moves_run_;
  return s;
}

int StageSummary::resamplings() const {
  int n = 0;
  for (const auto& s : steps) n += s.resampled ? 1 : 0;
  return n;
}

std::string StageSummary::BriefReport() const {
  std::ostringstream os;
  os << "stage " << stage << " '" << label << "': " << steps.size() << " steps, " << resamplings()
     << " resampled, log Z increment " << std::setprecision(10) << log_evidence_increment << ", log Z "
     << log_evidence << ", final ESS " << std::setprecision(4) << final_ess << ", " << wall_time_s << " s";
  return os.str();
}

std::string StageSummary::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  os << "  step       phi    delta_phi  rCESS    ESS  resampled  logZ_inc  sweeps  moves (runs, acceptance), jump per block\n";
  for (const auto& s : steps) {
    os << "  " << std::setw(4) << s.step << "  " << std::setw(9) << std::setprecision(6) << s.phi << "  "
       << std::setw(10) << std::setprecision(4) << s.delta_phi << "  " << std::setw(5) << std::setprecision(3)
       << s.relative_cess << "  " << std::setw(6) << std::setprecision(5) << s.ess << "  " << std::setw(9)
       << (s.resampled ? "yes" : "no") << "  " << std::setw(8) << std::setprecision(5)
       << s.log_evidence_increment << "  " << std::setw(6) << s.mh.sweeps;
    for (const MoveRecord& m : s.mh.moves) {
      if (m.runs == 0) continue;
      os << "  " << m.move << (m.block.empty() ? "" : " " + m.block) << " x" << m.runs;
      if (!std::isnan(m.acceptance)) os << " " << std::setprecision(3) << m.acceptance;
    }
    for (std::size_t b = 0; b < s.mh.block_names.size(); ++b)
      os << "  jump " << s.mh.block_names[b] << " " << std::setprecision(3) << s.mh.jump[b];
    os << "\n";
  }
  return os.str();
}

}  // namespace ssrfleet::smc
