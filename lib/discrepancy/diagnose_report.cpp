#include "discrepancy/diagnose_report.hpp"

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/gnuplot_runner.hpp"
#include "io/posterior_json.hpp"
#include "util/errors.hpp"

namespace ssrfleet::discrepancy {

namespace {

nlohmann::json summary_json(const fleet::ParameterSummary& s) {
  return {{"mean", s.mean}, {"sd", s.sd}, {"q025", s.q025}, {"q975", s.q975}};
}

nlohmann::json parameters_json(const std::vector<ParameterEstimate>& params) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& p : params) {
    auto e = summary_json(p.posterior);
    e["unit"] = p.unit;
    e["null_value"] = p.null_value;
    j[p.name] = e;
  }
  return j;
}

nlohmann::json gap_json(const GapMeasures& g) {
  return {{"rms_standardised_mean_residual", g.rms_standardised_mean},
          {"systematic_gap", g.systematic_gap},
          {"coverage95", g.coverage95},
          {"stiffness_distribution", g.stiffness_distribution},
          {"mean_residual", g.mean_residual},
          {"standardised_mean_residual", g.standardised_mean}};
}

nlohmann::json checks_json(const CheckReport& report) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& c : report.checks) {
    a.push_back({{"check", std::string(fleet::check_name(c.kind))},
                 {"statistic", c.statistic},
                 {"replicated", c.replicated},
                 {"p_value", c.p_value},
                 {"failed", c.flagged},
                 {"sensor", c.sensor},
                 {"per_sensor", c.per_sensor}});
    if (!c.detail.empty()) a.back()["detail"] = c.detail;
  }
  return a;
}

nlohmann::json fit_json(const ModelFit& f) {
  nlohmann::json hyper = nlohmann::json::object();
  for (int j = 0; j < fleet::kHyperCount; ++j) hyper[std::string(fleet::kHyperNames[j])] = summary_json(f.hyper[j]);
  return {{"log_evidence", f.log_evidence},
          {"heldout_log_score", f.heldout_log_score},
          {"wall_s", f.wall_s},
          {"integrator_passes", f.integrator_passes},
          {"hyperparameters", hyper}};
}

std::string fixed(double v, int precision) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(precision) << v;
  return s.str();
}

std::string interval(const fleet::ParameterSummary& s) {
  std::ostringstream os;
  os << std::setprecision(4) << s.mean << " [" << s.q025 << ", " << s.q975 << "]";
  return os.str();
}

void write_checks_table(std::ostream& os, const DiagnoseResult& r) {
  const bool after = !r.effects.empty();
  os << "| check | statistic | p-value (base) | failed | where |" << (after ? " p-value (with " + r.model + ") |" : "")
     << "\n|---|---|---|---|---|" << (after ? "---|" : "") << "\n";
  for (std::size_t k = 0; k < r.checks_before.checks.size(); ++k) {
    const auto& c = r.checks_before.checks[k];
    os << "| " << fleet::check_name(c.kind) << " | " << fixed(c.statistic, 2) << " (replicated " << fixed(c.replicated, 2)
       << ") | " << fixed(c.p_value, 4) << " | " << (c.flagged ? "yes" : "no") << " | "
       << (c.sensor > 0 ? "sensor " + std::to_string(c.sensor) : (c.detail.empty() ? std::string("-") : c.detail)) << " |";
    if (after) os << " " << fixed(r.checks_after.checks[k].p_value, 4) << " |";
    os << "\n";
  }
}

void write_summary(std::ostream& os, const DiagnoseResult& r) {
  os << "# ssrfleet diagnose\n\n";
  os << "**Effect: " << r.effect << "** - " << r.description << "\n\n";
  os << "Verdict: **" << r.verdict << "**; effects named, in order: " << (r.effects.empty() ? "none" : r.model)
     << "; the model diagnose ends with: " << r.model << ".\n\n";
  if (r.effects.size() > 1) {
    os << "| step | effect added | log Bayes factor against the model before | held-out gain | systematic gap after |\n"
          "|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < r.steps.size(); ++k) {
      const auto& st = r.steps[k];
      if (st.effect.empty()) continue;
      os << "| " << (k + 1) << " | " << st.effect << " | " << fixed(st.log_bayes_factor, 1) << " | "
         << fixed(st.heldout_gain, 1) << " | " << fixed(st.checks.gap.systematic_gap, 2) << " |\n";
    }
    os << "\n";
  }
  os << r.trucks << " trucks, " << r.sensors << " sensors; held-out skill scored on the last " << r.heldout_trucks
     << " trucks; checks fail at p < " << r.alpha << "; an effect needs log Bayes factor >= " << r.min_log_bayes_factor
     << " and a held-out gain > 0. Wall time " << fixed(r.wall_s, 1) << " s.\n\n";
  if (!r.effects.empty()) {
    os << "log Bayes factor against the base model: " << fixed(r.log_bayes_factor, 1) << "; held-out log score gain: "
       << fixed(r.heldout_gain, 1) << "\n\n| parameter | posterior mean [95 % interval] | base model's value |\n|---|---|---|\n";
    for (const auto& p : r.parameters) {
      os << "| " << p.name << (p.unit.empty() ? "" : " (" + p.unit + ")") << " | " << interval(p.posterior) << " | "
         << p.null_value << " |\n";
    }
    os << "\n";
    if (!r.alternatives.empty()) {
      os << "Evidence cannot tell it apart from:";
      for (const auto& alt : r.alternatives) os << " " << alt;
      os << " (log Bayes factors within " << r.min_log_bayes_factor << "; held-out skill chose " << r.effect
         << "; see the candidates below).\n\n";
    }
  }
  os << "## Gap between model and measurements\n\n| measure | base model | " << (r.effects.empty() ? "-" : r.model)
     << " |\n|---|---|---|\n";
  os << "| RMS standardised per-sensor mean residual (about 1 or less when the model fits) | "
     << fixed(r.checks_before.gap.rms_standardised_mean, 2) << " | " << fixed(r.checks_after.gap.rms_standardised_mean, 2)
     << " |\n";
  os << "| systematic part of it, sqrt(max(0, RMS^2 - 1)) (about 0 when the model fits) | "
     << fixed(r.checks_before.gap.systematic_gap, 2) << " | " << fixed(r.checks_after.gap.systematic_gap, 2) << " |\n";
  os << "| observed IFs inside their 95 % posterior predictive interval | " << fixed(100 * r.checks_before.gap.coverage95, 1)
     << " % | " << fixed(100 * r.checks_after.gap.coverage95, 1) << " % |\n";
  os << "| trucks' suspension stiffnesses against the fleet distribution, Anderson-Darling A^2 (about 1 or less when it fits) | "
     << fixed(r.checks_before.gap.stiffness_distribution, 2) << " | " << fixed(r.checks_after.gap.stiffness_distribution, 2)
     << " |\n\n";
  os << "## Posterior predictive checks\n\n";
  write_checks_table(os, r);
  os << "\n## Candidates\n\n| extension | failed checks in its signature | log Bayes factor | held-out gain | estimate | verdict |\n"
        "|---|---|---|---|---|---|\n";
  for (const auto& c : r.candidates) {
    std::string matched;
    for (const auto& m : c.matched_checks) {
      if (!matched.empty()) matched += ", ";
      matched += m;
    }
    std::string estimate;
    for (const auto& p : c.parameters) {
      if (!estimate.empty()) estimate += "; ";
      estimate += p.name;
      estimate += " ";
      estimate += interval(p.posterior);
    }
    os << "| " << c.name << " | " << (matched.empty() ? "-" : matched) << " | " << fixed(c.log_bayes_factor, 1) << " | "
       << fixed(c.heldout_gain, 1) << " | " << (estimate.empty() ? "-" : estimate) << " | " << c.verdict << " |\n";
  }
}

std::string residual_plot() {
  return io::png_and_svg_script(
      "residual_pattern",
      "set title \"Per-sensor mean residual (observed - model), before and after the named effect\"\n"
      "set xlabel 'position along the road (m)'\nset ylabel 'mean residual of IF (-)'\n"
      "set grid lc rgb '#dddddd'\nset key outside top center horizontal\n"
      "plot 'residual_pattern.csv' skip 1 using 2:7:8 with filledcurves lc rgb '#dddddd' title '95 % band of a right model', \\\n"
      "     '' skip 1 using 2:3 with linespoints lw 2 lc rgb '#c0392b' pt 7 title 'base model', \\\n"
      "     '' skip 1 using 2:4 with linespoints lw 2 lc rgb '#1f4e9c' pt 5 dt 2 title 'with the named effect'\n");
}

// One line per step of residual_steps.csv: base, then after each effect added.
std::string residual_steps_plot(std::size_t steps) {
  std::string plot =
      "set title \"Each sensor's standardised mean residual: base model, then after each effect added\"\n"
      "set xlabel 'position along the road (m)'\nset ylabel 'standardised mean residual (-)'\n"
      "set grid lc rgb '#dddddd'\nset key outside top center horizontal\nset datafile separator ','\n"
      "plot 1.96 with lines lc rgb '#999999' dt 3 notitle, -1.96 with lines lc rgb '#999999' dt 3 notitle, \\\n"
      "     'residual_steps.csv' skip 1 using 2:3 with linespoints lw 2 pt 7 title 'base model'";
  for (std::size_t k = 0; k < steps; ++k) {
    plot += ", \\\n     '' skip 1 using 2:" + std::to_string(4 + k) + " with linespoints lw 2 dt " + std::to_string(2 + k) +
            " title 'after effect " + std::to_string(k + 1) + "'";
  }
  return io::png_and_svg_script("residual_steps", plot + "\n", 900, 500);
}

std::string checks_plot() {
  return io::png_and_svg_script(
      "checks",
      "set grid lc rgb '#dddddd'\nset key outside top center horizontal\nset xlabel 'sensor'\n"
      "set multiplot layout 3,1 title 'Posterior predictive checks per sensor (solid: base model; dashed: with the named effect)'\n"
      "set ylabel 'standardised mean residual'\n"
      "plot 'per_sensor_checks.csv' skip 1 using 1:3 with linespoints lw 2 lc rgb '#c0392b' pt 7 title 'base', \\\n"
      "     '' skip 1 using 1:8 with linespoints lw 2 lc rgb '#1f4e9c' pt 5 dt 2 title 'with effect', \\\n"
      "     1.96 with lines lc rgb '#999999' dt 3 notitle, -1.96 with lines lc rgb '#999999' dt 3 notitle\n"
      "set ylabel 'dispersion ratio (var / sigma^2)'\n"
      "plot 'per_sensor_checks.csv' skip 1 using 1:4 with linespoints lw 2 lc rgb '#c0392b' pt 7 title 'base', \\\n"
      "     '' skip 1 using 1:9 with linespoints lw 2 lc rgb '#1f4e9c' pt 5 dt 2 title 'with effect', \\\n"
      "     1 with lines lc rgb '#999999' dt 3 notitle\n"
      "set ylabel 'correlation of residual with'\n"
      "plot 'per_sensor_checks.csv' skip 1 using 1:5 with linespoints lw 2 lc rgb '#c0392b' pt 7 title 'speed (base)', \\\n"
      "     '' skip 1 using 1:6 with linespoints lw 2 lc rgb '#e67e22' pt 9 title 'mass (base)', \\\n"
      "     '' skip 1 using 1:7 with linespoints lw 2 lc rgb '#8e44ad' pt 11 title 'lateral (base)', \\\n"
      "     '' skip 1 using 1:10 with linespoints lw 2 lc rgb '#c0392b' pt 6 dt 2 title 'speed (effect)'\n"
      "unset multiplot\n",
      900, 1000);
}

const CheckResult& find_check(const CheckReport& r, fleet::CheckKind kind) {
  for (const auto& c : r.checks) {
    if (c.kind == kind) return c;
  }
  throw std::logic_error("check report without " + std::string(fleet::check_name(kind)));
}

double per_sensor(const CheckReport& r, fleet::CheckKind kind, int m) {
  const auto& v = find_check(r, kind).per_sensor;
  return static_cast<std::size_t>(m) < v.size() ? v[static_cast<std::size_t>(m)] : std::nan("");
}

nlohmann::json candidates_json(const std::vector<CandidateResult>& list) {
  nlohmann::json candidates = nlohmann::json::array();
  for (const auto& c : list) {
    nlohmann::json e = {{"name", c.name},
                        {"description", c.description},
                        {"matched_checks", c.matched_checks},
                        {"refitted", c.refitted},
                        {"verdict", c.verdict}};
    if (c.refitted) {
      e["log_evidence"] = c.fit.log_evidence;
      e["log_bayes_factor"] = c.log_bayes_factor;
      e["heldout_gain"] = c.heldout_gain;
      e["parameters"] = parameters_json(c.parameters);
      e["wall_s"] = c.fit.wall_s;
    }
    candidates.push_back(e);
  }
  return candidates;
}

}  // namespace

nlohmann::json diagnosis_to_json(const DiagnoseResult& r) {
  nlohmann::json j;
  j["effect"] = r.effect;
  j["description"] = r.description;
  j["parameters"] = parameters_json(r.parameters);
  j["alternatives"] = r.alternatives;
  j["log_bayes_factor"] = r.log_bayes_factor;
  j["heldout_gain"] = r.heldout_gain;
  j["gap_before"] = gap_json(r.checks_before.gap);
  j["gap_after"] = gap_json(r.checks_after.gap);
  j["checks_before"] = checks_json(r.checks_before);
  j["checks_after"] = checks_json(r.checks_after);
  j["effects"] = r.effects;
  j["verdict"] = r.verdict;
  j["model"] = r.model;
  j["candidates"] = candidates_json(r.candidates);
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& step : r.steps) {
    nlohmann::json e = {{"effect", step.effect.empty() ? nlohmann::json(nullptr) : nlohmann::json(step.effect)},
                        {"candidates", candidates_json(step.candidates)},
                        {"wall_s", step.wall_s}};
    if (!step.effect.empty()) {
      e["model"] = step.model;
      e["log_bayes_factor"] = step.log_bayes_factor;
      e["heldout_gain"] = step.heldout_gain;
      e["gap"] = gap_json(step.checks.gap);
      e["checks"] = checks_json(step.checks);
    }
    steps.push_back(e);
  }
  j["steps"] = steps;
  j["base"] = fit_json(r.base);
  j["chosen"] = fit_json(r.chosen);
  j["trucks"] = r.trucks;
  j["heldout_trucks"] = r.heldout_trucks;
  j["alpha"] = r.alpha;
  j["min_log_bayes_factor"] = r.min_log_bayes_factor;
  j["wall_s"] = r.wall_s;
  return j;
}

void print_diagnosis(std::ostream& os, const DiagnoseResult& r) { write_summary(os, r); }

std::vector<std::string> write_diagnosis_files(const std::string& dir, const DiagnoseResult& r, bool plots,
                                               bool* plotted) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw IoError("diagnose: cannot create " + dir + ": " + ec.message());
  std::vector<std::string> files;
  const auto write = [&](const std::string& name, const std::function<void(std::ostream&)>& body) {
    io::write_file_atomically((std::filesystem::path(dir) / name).string(), body);
    files.push_back(name);
  };
  // The posterior diagnose ends with, ready for predict (the chosen effect's model, or the base).
  if (r.posterior.theta.cols() > 0) {
    write("posterior.json", [&](std::ostream& os) {
      os << io::posterior_file_text(
          io::posterior_to_json(r.posterior, fleet::summarise_cloud(r.posterior), fleet::summarise_psi(r.posterior)));
    });
  }
  const auto& before = r.checks_before;
  const auto& after = r.checks_after;
  const double n = static_cast<double>(r.trucks);
  write("residual_pattern.csv", [&](std::ostream& os) {
    os << std::setprecision(8)
       << "sensor,position_m,mean_residual_base,mean_residual_effect,standardised_base,standardised_effect,band_lower,band_upper\n";
    const double sigma = r.base.hyper[fleet::kSigmaIf].mean;
    for (int m = 0; m < r.sensors; ++m) {
      const auto k = static_cast<std::size_t>(m);
      os << (m + 1) << ',' << r.sensor_positions_m[k] << ',' << before.gap.mean_residual[k] << ','
         << after.gap.mean_residual[k] << ',' << before.gap.standardised_mean[k] << ',' << after.gap.standardised_mean[k]
         << ',' << -1.96 * sigma / std::sqrt(n) << ',' << 1.96 * sigma / std::sqrt(n) << '\n';
    }
  });
  write("per_sensor_checks.csv", [&](std::ostream& os) {
    using fleet::CheckKind;
    os << std::setprecision(6)
       << "sensor,position_m,z_mean_base,dispersion_base,corr_speed_base,corr_mass_base,corr_lateral_base,"
          "z_mean_effect,dispersion_effect,corr_speed_effect\n";
    for (int m = 0; m < r.sensors; ++m) {
      os << (m + 1) << ',' << r.sensor_positions_m[static_cast<std::size_t>(m)] << ','
         << per_sensor(before, CheckKind::kSensorMean, m) << ',' << per_sensor(before, CheckKind::kSensorDispersion, m)
         << ',' << per_sensor(before, CheckKind::kSpeed, m) << ',' << per_sensor(before, CheckKind::kMass, m) << ','
         << per_sensor(before, CheckKind::kLateral, m) << ',' << per_sensor(after, CheckKind::kSensorMean, m) << ','
         << per_sensor(after, CheckKind::kSensorDispersion, m) << ',' << per_sensor(after, CheckKind::kSpeed, m) << '\n';
    }
  });
  write("checks.csv", [&](std::ostream& os) {
    os << std::setprecision(8) << "model,check,statistic,replicated,p_value,failed,sensor\n";
    const auto rows = [&](const std::string& model, const CheckReport& rep) {
      for (const auto& c : rep.checks) {
        os << model << ',' << fleet::check_name(c.kind) << ',' << c.statistic << ',' << c.replicated << ',' << c.p_value
           << ',' << (c.flagged ? 1 : 0) << ',' << c.sensor << '\n';
      }
    };
    rows("base", before);
    for (const auto& step : r.steps) {
      if (!step.effect.empty()) rows(step.model, step.checks);
    }
  });
  // The gap at each step: every sensor's standardised mean residual before, after the first
  // effect, after the second, ...
  std::vector<const DiagnoseStep*> added;
  for (const auto& step : r.steps) {
    if (!step.effect.empty()) added.push_back(&step);
  }
  write("residual_steps.csv", [&](std::ostream& os) {
    os << std::setprecision(6) << "sensor,position_m,base";
    for (const auto* step : added) os << ',' << step->model;
    os << '\n';
    for (int m = 0; m < r.sensors; ++m) {
      const auto k = static_cast<std::size_t>(m);
      os << (m + 1) << ',' << r.sensor_positions_m[k] << ',' << before.gap.standardised_mean[k];
      for (const auto* step : added) os << ',' << step->checks.gap.standardised_mean[k];
      os << '\n';
    }
  });
  write("summary.md", [&](std::ostream& os) { write_summary(os, r); });
  write("report.json", [&](std::ostream& os) { os << diagnosis_to_json(r).dump(1) << '\n'; });
  const std::vector<io::PlotScript> scripts = {{"residual_pattern", residual_plot()},
                                               {"checks", checks_plot()},
                                               {"residual_steps", residual_steps_plot(added.size())}};
  for (const auto& s : scripts) write(s.name + ".gp", [&](std::ostream& os) { os << s.script; });
  bool ok = false;
  if (plots && io::gnuplot_available()) {
    ok = io::run_gnuplot(dir, scripts).empty();
    if (ok) {
      for (const auto& s : scripts) files.push_back(s.name + ".png"), files.push_back(s.name + ".svg");
    }
  }
  if (plotted) *plotted = ok;
  return files;
}

}  // namespace ssrfleet::discrepancy
