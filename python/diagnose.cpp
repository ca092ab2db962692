// ssrfleet.diagnose: `ssrfleet diagnose` as a function (bin/cmd_diagnose.cpp). The options become
// discrepancy::DiagnoseOptions as the command's flags do, the library runs the same search, and the
// report is the command's JSON (--json), returned as text for the package to parse, beside the
// posterior diagnose ends with; the command's files are written when asked for.
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "cli_common.hpp"
#include "discrepancy/diagnose.hpp"
#include "discrepancy/diagnose_report.hpp"
#include "fleet/posterior_summary.hpp"
#include "io/posterior_json.hpp"
#include "log_arrays.hpp"
#include "model/model_extension.hpp"
#include "posterior_handle.hpp"
#include "site_handle.hpp"
#include "smc/engine.hpp"
#include "stoppable.hpp"
#include "util/errors.hpp"

namespace py = pybind11;

namespace ssrfleet::python {

namespace {

py::tuple diagnose(const SiteHandle& where, const std::optional<std::string>& log_path,
                   const py::object& arrays, std::uint64_t seed, const py::dict& options,
                   const std::optional<std::string>& json_path, const std::optional<std::string>& out_dir,
                   const std::optional<std::string>& posterior_path, bool plots) {
  discrepancy::DiagnoseOptions o;
  int threads = 0;
  bool progress = false, refit_from_prior = false;
  take(options, "particles", o.particles);
  take(options, "threads", threads);
  take(options, "alpha", o.alpha);
  take(options, "min_log_bf", o.min_log_bayes_factor);
  take(options, "holdout", o.holdout_fraction);
  take(options, "candidates", o.candidates);
  take(options, "max_effects", o.max_effects);
  take(options, "shortlist_only", o.shortlist_only);
  take(options, "refit_from_prior", refit_from_prior);
  take(options, "draws", o.draws);
  take(options, "progress", progress);
  // The command's checks, in its order.
  cli::check_particles(o.particles);
  o.seed = seed;
  if (threads < 0) throw UsageError("threads must be >= 0 (0 = all cores)");
  o.threads = threads > 0 ? threads : smc::TemperedSampler::Options::default_threads();
  o.refit_from_tables = !refit_from_prior;
  o.validate();
  const site::Site& site = *where.site;
  for (const auto& name : o.candidates)
    fleet::make_extension(name, site);  // unknown names fail before any work
  if (progress) o.progress = &std::cerr;

  auto posterior = std::make_shared<PosteriorHandle>();
  posterior->site = where.site;
  posterior->seed = seed;
  posterior->source = "the result of ssrfleet.diagnose()";
  if (!log_path) posterior->records = read_log_arrays(arrays.cast<py::tuple>(), where, io::WimLimits{});
  std::string report;
  run_stoppable([&](const util::StopToken&) {
    if (log_path) posterior->records = cli::read_site_log(*log_path, site, where.flags);
    if (!posterior->records.empty() && !posterior->records.front().vehicle_class.empty()) {
      std::cerr << "ssrfleet.diagnose: warning: the log's class column is ignored: diagnose fits all its "
                   "trucks as one "
                   "fleet (fit the classes apart with fit, or diagnose each class's records alone)\n";
    }
    const auto result = discrepancy::diagnose(site, posterior->records, o);
    report = discrepancy::diagnosis_to_json(result).dump(1) + "\n";
    if (json_path) cli::write_output(*json_path, [&](std::ostream& os) { os << report; });
    if (posterior_path) {
      cli::write_output(*posterior_path, [&](std::ostream& os) {
        os << io::posterior_file_text(io::posterior_to_json(result.posterior,
                                                            fleet::summarise_cloud(result.posterior),
                                                            fleet::summarise_psi(result.posterior)));
      });
    }
    if (out_dir) discrepancy::write_diagnosis_files(*out_dir, result, plots, nullptr);
    posterior->classes.push_back({"", result.posterior});
  });
  return py::make_tuple(report, posterior);
}

}  // namespace

void bind_diagnose(py::module_& m) {
  m.def("_diagnose", &diagnose, py::arg("site"), py::arg("log_path"), py::arg("arrays"), py::arg("seed"),
        py::arg("options"), py::arg("json"), py::arg("out"), py::arg("posterior_out"), py::arg("plots"));
}

}  // namespace ssrfleet::python
