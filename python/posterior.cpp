// fit, the posterior, predict and damage: `ssrfleet fit`, `predict` and `damage` as functions. The fit runs
// the commands' own code (bin/fit_methods.hpp: fit_smc, fit_mcmc, FitFlags) class by class with
// the classes' seeds, and the posterior file is written by the same functions as the command's, so
// a seed gives the command's file to the byte.
#include <cmath>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "cli_common.hpp"
#include "damage/damage_profile.hpp"
#include "draws_output.hpp"
#include "fit_methods.hpp"
#include "fit_sites.hpp"
#include "fleet/equal_weight_draws.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/damage_csv.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "log_arrays.hpp"
#include "model/fleet_model.hpp"
#include "model/model_spec.hpp"
#include "posterior_handle.hpp"
#include "predict/ssr_prediction.hpp"
#include "site_handle.hpp"
#include "stoppable.hpp"
#include "util/errors.hpp"

namespace py = pybind11;

namespace ssrfleet::python {

namespace {

std::shared_ptr<PosteriorHandle> fit(const SiteHandle& where, const std::optional<std::string>& log_path,
                                     const py::object& arrays, const std::string& method, std::uint64_t seed,
                                     const py::dict& options) {
  cli::FitFlags flags;
  take(options, "model", flags.model);
  flags.core_given = take(options, "core", flags.core);
  take(options, "particles", flags.particles);
  take(options, "threads", flags.threads);
  take(options, "older_sweeps", flags.older_sweeps);
  flags.final_sweeps_given = take(options, "final_sweeps", flags.final_sweeps);
  take(options, "cess", flags.cess_target);
  flags.max_sweeps_given = take(options, "max_sweeps", flags.max_sweeps);
  take(options, "iterations", flags.iterations);
  take(options, "burn_in", flags.burn_in);
  take(options, "thin", flags.thin);
  const bool chains_given = take(options, "chains", flags.chains);
  const bool runs_given = take(options, "runs", flags.runs);
  take(options, "checkpoint", flags.checkpoint_dir);
  take(options, "checkpoint_every_s", flags.checkpoint_every_s);
  take(options, "checkpoint_every_trucks", flags.checkpoint_every_trucks);
  std::string manifest;
  take(options, "sites", manifest);
  bool fhwa = false, progress = false;
  take(options, "fhwa_classes", fhwa);
  take(options, "progress", progress);
  if (flags.threads < 0) throw UsageError("threads must be >= 0 (0 = all cores)");

  // The command's checks, in its order.
  cli::check_particles(flags.particles);
  if (method != "smc" && method != "mcmc") throw UsageError("method '" + method + "': must be smc or mcmc");
  if (method == "mcmc" && runs_given) {
    throw UsageError("runs repeats the SMC; the batch MCMC's independent runs are its chains");
  }
  if (method == "smc" && chains_given) {
    throw UsageError("chains are the batch MCMC's (method='mcmc'); the SMC's independent runs are runs");
  }
  if (method == "mcmc" && !flags.checkpoint_dir.empty()) {
    throw UsageError(
        "checkpoint: checkpoints are the SMC's (a batch MCMC chain is not resumed); use method='smc'");
  }
  if (!manifest.empty()) {
    // fit --sites MANIFEST: the command's own function writes the posterior file (here a file the
    // package gives and reads back), so the posterior is the command's to the byte.
    std::string out_path;
    take(options, "sites_out", out_path);
    io::WimLimits limits;
    limits.fhwa_classes = fhwa;
    cli::JointFitRequest request;
    request.manifest_path = manifest;
    request.out = out_path;
    request.method = method;
    request.seed = seed;
    request.quiet = !progress;
    run_stoppable(
        [&](const util::StopToken&) { cli::fit_manifest_sites(request, flags, where.flags, limits); });
    auto out = std::make_shared<PosteriorHandle>();
    out->classes = io::read_posterior_classes(out_path);
    out->seed = seed;
    std::ifstream written(out_path, std::ios::binary);
    out->file_text.assign(std::istreambuf_iterator<char>(written), std::istreambuf_iterator<char>());
    return out;
  }
  const site::Site& site = *where.site;
  const fleet::ModelSpec model = fleet::parse_model_spec(flags.model, site);
  io::WimLimits limits;
  limits.fhwa_classes = fhwa;

  auto out = std::make_shared<PosteriorHandle>();
  out->site = where.site;
  out->seed = seed;
  if (!log_path) out->records = read_log_arrays(arrays.cast<py::tuple>(), where, limits);
  std::ostream* stream = progress ? &std::cerr : nullptr;
  run_stoppable([&](const util::StopToken&) {
    if (log_path) out->records = cli::read_site_log(*log_path, site, where.flags, limits);
    // fit_classes_to_file's loop (bin/fit_classes.cpp) without its file: each class with its seed.
    for (const auto& [label, class_records] : fleet::split_by_class(out->records)) {
      const std::uint64_t class_seed = fleet::class_seed(seed, label);
      fleet::PosteriorCloud cloud =
          method == "smc"
              ? cli::fit_smc(site, class_records, flags, class_seed, stream, model.extension.get())
              : cli::fit_mcmc(site, class_records, flags, class_seed, stream, model.extension.get());
      out->classes.push_back({label, std::move(cloud)});
    }
  });
  return out;
}

std::shared_ptr<PosteriorHandle> read_posterior(const std::string& path) {
  auto out = std::make_shared<PosteriorHandle>();
  py::gil_scoped_release release;
  out->classes = io::read_posterior_classes(path);
  out->source = path;
  return out;
}

// The class asked for; an unlabelled posterior is its one class.
const fleet::PosteriorCloud& cloud_of(const PosteriorHandle& p, const std::optional<std::string>& label) {
  if (!label) {
    if (fleet::unlabelled(p.classes) || p.classes.size() == 1) return p.classes.front().cloud;
    throw UsageError("the posterior has vehicle classes " + fleet::list_labels(p.classes) +
                     ": give vehicle_class=LABEL");
  }
  for (const auto& c : p.classes) {
    if (c.label == *label) return c.cloud;
  }
  throw UsageError("vehicle_class '" + *label + "': the posterior's classes are " +
                   fleet::list_labels(p.classes));
}

std::vector<std::string> parameter_names(const fleet::PosteriorCloud& cloud) {
  std::vector<std::string> names(fleet::kHyperNames.begin(), fleet::kHyperNames.end());
  names.insert(names.end(), cloud.psi_names.begin(), cloud.psi_names.end());
  return names;
}

py::dict summary(const PosteriorHandle& p, const std::optional<std::string>& label) {
  const fleet::PosteriorCloud& cloud = cloud_of(p, label);
  std::vector<fleet::ParameterSummary> all = fleet::summarise_cloud(cloud);
  const std::vector<fleet::ParameterSummary> psi = fleet::summarise_psi(cloud);
  all.insert(all.end(), psi.begin(), psi.end());
  const std::vector<std::string> names = parameter_names(cloud);
  py::dict out;
  for (std::size_t i = 0; i < all.size() && i < names.size(); ++i) {
    py::dict s;
    s["mean"] = all[i].mean;
    s["sd"] = all[i].sd;
    s["q025"] = all[i].q025;
    s["q975"] = all[i].q975;
    out[py::str(names[i])] = s;
  }
  return out;
}

py::tuple draws(const PosteriorHandle& p, const std::optional<std::string>& label) {
  const fleet::PosteriorCloud& cloud = cloud_of(p, label);
  const fleet::EqualWeightDraws d = fleet::equal_weight_draws(cloud);
  const auto hyper = static_cast<py::ssize_t>(d.theta.rows()), psi = static_cast<py::ssize_t>(d.psi.rows());
  const py::ssize_t chains = d.chains, per_chain = d.draws;
  py::array_t<double> out({chains, per_chain, hyper + psi});
  auto a = out.mutable_unchecked<3>();
  for (py::ssize_t c = 0; c < chains; ++c) {
    for (py::ssize_t k = 0; k < per_chain; ++k) {
      const Eigen::Index column = c * per_chain + k;
      for (py::ssize_t q = 0; q < hyper; ++q) a(c, k, q) = d.theta(q, column);
      for (py::ssize_t q = 0; q < psi; ++q) a(c, k, hyper + q) = d.psi(q, column);
    }
  }
  return py::make_tuple(out, parameter_names(cloud));
}

py::dict convergence(const PosteriorHandle& p, const std::optional<std::string>& label) {
  const fleet::PosteriorCloud& cloud = cloud_of(p, label);
  py::dict out;
  for (const auto& c : cloud.convergence) {
    py::dict d;
    d["rhat"] = c.rhat;
    d["ess_bulk"] = c.ess_bulk;
    d["ess_tail"] = c.ess_tail;
    d["ess_equivalent"] = c.ess_equivalent;
    d["mcse_mean"] = c.mcse_mean;
    d["mcse_q05"] = c.mcse_q05;
    d["mcse_q95"] = c.mcse_q95;
    out[py::str(c.name)] = d;
  }
  return out;
}

// The posterior file, as fit_classes_to_file writes it (bin/fit_classes.cpp).
void to_json(const PosteriorHandle& p, const std::string& path) {
  if (!p.file_text.empty()) {
    cli::write_output(path, [&](std::ostream& os) { os << p.file_text; });
    return;
  }
  py::gil_scoped_release release;
  std::vector<std::vector<fleet::ParameterSummary>> hyper, psi;
  for (const auto& c : p.classes) {
    hyper.push_back(fleet::summarise_cloud(c.cloud));
    psi.push_back(fleet::summarise_psi(c.cloud));
  }
  cli::write_output(path, [&](std::ostream& os) {
    os << io::posterior_file_text(io::posterior_classes_to_json(p.classes, hyper, psi));
  });
}

// The draws file (docs/draws.md) as fit --draws-out writes it: with the fitted log as observed
// data and the posterior predictive when the posterior came from a fit here.
void write_draws(const PosteriorHandle& p, const std::string& path, const std::optional<std::string>& label) {
  cli::draws_format(path, "path");
  const fleet::PosteriorCloud& cloud = cloud_of(p, label);
  cli::DrawsExtras extras;
  std::vector<records::WimRecord> class_records;
  if (!p.records.empty()) {
    if (label && !label->empty()) {
      for (const auto& r : p.records) {
        if (r.vehicle_class == *label) class_records.push_back(r);
      }
      extras.observed = &class_records;
    } else {
      extras.observed = &p.records;
    }
    extras.site = p.site.get();
    extras.seed = p.seed;
  }
  run_stoppable([&](const util::StopToken&) { cli::write_draws(path, cloud, extras); });
}

// Where predict and damage look: positions checked as --positions is (finite, strictly
// increasing); the classes and shares that vehicle_class / mix ask for, as the commands'
// --class / --mix; the fitted site unless new_road.
struct Selection {
  fleet::ClassPosteriors classes;
  std::vector<double> shares;
};
Selection select(const PosteriorHandle& p, const SiteHandle& where, const std::vector<double>& positions,
                 bool new_road, const std::optional<std::string>& label, const std::string& mix) {
  for (std::size_t i = 0; i < positions.size(); ++i) {
    if (!std::isfinite(positions[i]))
      throw UsageError("positions[" + std::to_string(i) + "] is not a finite number");
    if (i > 0 && !(positions[i] > positions[i - 1])) {
      throw UsageError("positions[" + std::to_string(i) + "]: positions must be strictly increasing");
    }
  }
  if (label && !mix.empty()) throw UsageError("give vehicle_class or mix, not both");
  Selection s;
  s.classes = p.classes;
  if (fleet::unlabelled(s.classes) && (label || !mix.empty())) {
    throw UsageError(std::string(label ? "vehicle_class" : "mix") + ": the posterior has no vehicle classes");
  }
  if (label) s.classes = fleet::select_class(s.classes, *label);
  s.shares = fleet::class_shares(s.classes, fleet::parse_mix(mix, "mix"));
  if (!new_road) {
    cli::require_fitted_site(s.classes.front().cloud, p.source, *where.site,
                             "; pass new_road=True to work on a different road on purpose");
  }
  return s;
}

py::array_t<double> array_of(const std::vector<double>& v) {
  return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}
py::array_t<double> array_of(const Eigen::ArrayXd& a) {
  return py::array_t<double>(static_cast<py::ssize_t>(a.size()), a.data());
}

// `ssrfleet predict`.
py::dict predict(const PosteriorHandle& p, const SiteHandle& where, const std::vector<double>& positions,
                 int draws, int trucks_per_draw, std::uint64_t seed, bool fixed_traffic, bool new_road,
                 const std::optional<std::string>& label, const std::string& mix,
                 const std::optional<std::string>& out) {
  predict::PredictionOptions options;
  options.theta_draws = draws;
  options.trucks_per_draw = trucks_per_draw;
  options.seed = seed;
  options.traffic_bootstrap = !fixed_traffic;
  options.validate();
  const Selection s = select(p, where, positions, new_road, label, mix);
  const fleet::ClassPosteriors& classes = s.classes;
  const std::vector<double>& shares = s.shares;
  predict::SsrPrediction prediction;
  run_stoppable([&](const util::StopToken&) {
    prediction = predict::predict_ssr_mixture(classes, shares, *where.site, positions, options);
    if (out)
      cli::write_output(*out, [&](std::ostream& os) { predict::write_prediction_csv(os, prediction); });
  });
  py::dict result;
  result["position_m"] = array_of(prediction.position_m);
  result["mean_if"] = array_of(prediction.mean_if);
  result["lower95"] = array_of(prediction.lower95);
  result["upper95"] = array_of(prediction.upper95);
  result["mean_lower95"] = array_of(prediction.mean_lower95);
  result["mean_upper95"] = array_of(prediction.mean_upper95);
  return result;
}

// `ssrfleet damage`: the damage profile as arrays, each power n's amplification under the CSV's
// column names (a1, a1_q025, a1_q975, a4, ...).
py::dict damage(const PosteriorHandle& p, const SiteHandle& where, const std::vector<double>& positions,
                const std::vector<double>& powers, double threshold, int draws, int trucks_per_draw,
                std::uint64_t seed, bool fixed_traffic, bool new_road,
                const std::optional<std::string>& label, const std::string& mix,
                const std::optional<std::string>& out) {
  damage::DamageOptions options;
  options.extra_powers = powers;
  options.hot_spot_threshold = threshold;
  options.theta_draws = draws;
  options.trucks_per_draw = trucks_per_draw;
  options.seed = seed;
  options.traffic_bootstrap = !fixed_traffic;
  options.validate();
  const Selection s = select(p, where, positions, new_road, label, mix);
  records::DamageProfile profile;
  run_stoppable([&](const util::StopToken&) {
    profile = damage::predict_damage_mixture(s.classes, s.shares, *where.site, positions, options);
    if (out) cli::write_output(*out, [&](std::ostream& os) { io::write_damage_csv(os, profile); });
  });
  py::dict result;
  result["position_m"] = array_of(profile.position_m);
  result["dlc"] = array_of(profile.dlc);
  for (const auto& a : profile.powers) {
    const std::string c = io::power_column(a.power);
    result[py::str(c)] = array_of(a.mean);
    result[py::str(c + "_q025")] = array_of(a.q025);
    result[py::str(c + "_q975")] = array_of(a.q975);
  }
  py::array_t<bool> hot(static_cast<py::ssize_t>(profile.hot_spot.size()));
  auto h = hot.mutable_unchecked<1>();
  for (std::size_t m = 0; m < profile.hot_spot.size(); ++m)
    h(static_cast<py::ssize_t>(m)) = profile.hot_spot[m];
  result["hot_spot"] = hot;
  result["hot_spot_threshold"] = profile.hot_spot_threshold;
  result["esal_per_million"] = array_of(profile.esal_per_million);
  result["esal_per_million_q025"] = array_of(profile.esal_per_million_q025);
  result["esal_per_million_q975"] = array_of(profile.esal_per_million_q975);
  result["static_esal_per_million"] = profile.static_esal_per_million;
  result["lift_off_passes"] = profile.lift_off_passes;
  result["simulated_passes"] = profile.simulated_passes;
  return result;
}

}  // namespace

void bind_posterior(py::module_& m) {
  py::class_<PosteriorHandle, std::shared_ptr<PosteriorHandle>>(m, "_Posterior")
      .def_property_readonly("labels",
                             [](const PosteriorHandle& p) {
                               std::vector<std::string> l;
                               for (const auto& c : p.classes) l.push_back(c.label);
                               return l;
                             })
      .def_property_readonly("has_fit_site", [](const PosteriorHandle& p) { return p.site != nullptr; })
      .def(
          "info",
          [](const PosteriorHandle& p, const std::optional<std::string>& label) {
            const fleet::PosteriorCloud& c = cloud_of(p, label);
            py::dict d;
            d["method"] = c.method;
            d["model"] = c.model;
            d["chains"] = c.chains;
            d["trucks_seen"] = c.trucks_seen;
            d["particles"] = c.theta.cols();
            d["weight_ess"] = c.weight_ess;
            d["min_ess"] = c.min_ess;
            d["log_evidence"] = c.log_evidence;
            d["road_name"] = c.road_name;
            d["site_fingerprint"] = c.site_fingerprint;
            d["sensors"] = c.sensors;
            d["parameters"] = parameter_names(c);
            return d;
          },
          py::arg("vehicle_class") = py::none())
      .def("summary", &summary, py::arg("vehicle_class") = py::none())
      .def("draws", &draws, py::arg("vehicle_class") = py::none())
      .def("convergence", &convergence, py::arg("vehicle_class") = py::none())
      .def("to_json", &to_json, py::arg("path"))
      .def("write_draws", &write_draws, py::arg("path"), py::arg("vehicle_class") = py::none())
      .def("predict", &predict, py::arg("site"), py::arg("positions"), py::arg("draws"),
           py::arg("trucks_per_draw"), py::arg("seed"), py::arg("fixed_traffic"), py::arg("new_road"),
           py::arg("vehicle_class"), py::arg("mix"), py::arg("out"))
      .def("damage", &damage, py::arg("site"), py::arg("positions"), py::arg("powers"), py::arg("threshold"),
           py::arg("draws"), py::arg("trucks_per_draw"), py::arg("seed"), py::arg("fixed_traffic"),
           py::arg("new_road"), py::arg("vehicle_class"), py::arg("mix"), py::arg("out"));
  m.def("_fit", &fit, py::arg("site"), py::arg("log_path"), py::arg("arrays"), py::arg("method"),
        py::arg("seed"), py::arg("options"));
  m.def("_read_posterior", &read_posterior, py::arg("path"));
}

}  // namespace ssrfleet::python
