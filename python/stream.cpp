// ssrfleet.Stream: `ssrfleet stream` as an object over the same state directory. The options are
// turned into the stream's as the command turns its flags (bin/cmd_stream.cpp), so a state made by
// either is resumed by the other, to the same posterior bit for bit. push runs the library's record
// loop (stream::WimStream::run) on a file, or on the WIM log CSV of arrays (log_arrays.hpp): good
// records are absorbed, bad ones quarantined in rejects.csv, as the command does.
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "cli_common.hpp"
#include "log_arrays.hpp"
#include "model/model_spec.hpp"
#include "records/vehicle_class.hpp"
#include "site_handle.hpp"
#include "stoppable.hpp"
#include "stream/wim_stream.hpp"
#include "util/errors.hpp"

namespace py = pybind11;

namespace ssrfleet::python {

namespace {

struct StreamHandle {
  std::shared_ptr<const site::Site> site;  // the stream keeps a reference: it lives as long
  fleet::ModelSpec model;                  // the extension the stream's options point at
  std::ostream discard{nullptr};           // the command's SSR tables (standard output): not wanted here
  std::unique_ptr<stream::WimStream> stream;
  std::string state_dir;
  std::mutex busy;  // one call at a time (the work runs with the GIL released)
};

std::shared_ptr<StreamHandle> open_stream(const SiteHandle& where, const std::string& state_dir,
                                          std::uint64_t seed, const py::dict& o) {
  auto h = std::make_shared<StreamHandle>();
  h->site = where.site;
  h->state_dir = state_dir;
  stream::StreamOptions options;
  options.state_dir = state_dir;
  long particles = 1024;
  int threads = 0;
  std::string model_text = "base";
  std::vector<std::string> classes;
  bool progress = false;
  take(o, "particles", particles);
  take(o, "threads", threads);
  take(o, "model", model_text);
  take(o, "classes", classes);
  take(o, "fhwa_classes", options.limits.fhwa_classes);
  take(o, "tables_in_memory", options.tables_in_memory);
  take(o, "progress", progress);
  // The command's checks and settings, in its order (bin/cmd_stream.cpp).
  cli::check_particles(particles);
  if (threads < 0) throw UsageError("threads must be >= 0 (0 = all cores)");
  h->model = fleet::parse_model_spec(model_text, *h->site);
  options.fit.core = fleet::choose_core(h->model.extension.get());
  options.fit.extension = h->model.extension.get();
  options.fit.sampler().particles = particles;
  options.fit.sampler().threads = threads > 0 ? threads : smc::TemperedSampler::Options::default_threads();
  options.fit.sampler().seed = seed;
  std::string why;
  if (!options.fit.sampler().IsValid(&why)) throw UsageError(why);
  for (const std::string& label : classes) {
    if (!records::is_class_label(label))
      throw UsageError("classes: '" + label + "' is not a class label (one or more of A-Z a-z 0-9 _ . -)");
    if (options.limits.fhwa_classes && !records::is_fhwa_class(label))
      throw UsageError("classes: '" + label + "' is not an FHWA class (1 to 13)");
    options.classes.insert(label);
  }
  // The command prints an SSR table at the end of each run; here it goes nowhere, so it is made
  // as small as a prediction may be (posterior() and predict() give the real thing).
  options.prediction.theta_draws = 2;
  options.prediction.trucks_per_draw = 1;
  run_stoppable([&](const util::StopToken&) {
    h->stream =
        std::make_unique<stream::WimStream>(*h->site, options, progress ? &std::cerr : nullptr, h->discard);
  });
  return h;
}

py::dict counts_of(const stream::StreamCounts& c) {
  py::dict d;
  d["absorbed"] = c.absorbed;
  d["rejected"] = c.rejected;
  d["skipped"] = c.skipped;
  d["total_absorbed"] = c.total_absorbed;
  return d;
}

// The stream's record loop on `in`, stoppable: a Ctrl-C trips the token whose flag the loop
// watches, so the run ends after the record in hand with its state saved, and the Stream stays
// usable (a push of the same records again skips those absorbed).
py::dict run(StreamHandle& h, std::istream& in, const std::string& source) {
  stream::StreamCounts counts;
  run_stoppable([&](const util::StopToken& token) { counts = h.stream->run(in, source, token.flag()); },
                StopVia::kArgumentOnly);
  return counts_of(counts);
}

std::unique_lock<std::mutex> claim(StreamHandle& h) {
  std::unique_lock<std::mutex> lock(h.busy, std::try_to_lock);
  if (!lock.owns_lock())
    throw BusyError("the Stream on '" + h.state_dir + "' is in use by another thread's call");
  if (!h.stream) throw UsageError("the Stream on '" + h.state_dir + "' is closed");
  return lock;
}

}  // namespace

void bind_stream(py::module_& m) {
  py::class_<StreamHandle, std::shared_ptr<StreamHandle>>(m, "_Stream")
      .def_property_readonly("resumed",
                             [](StreamHandle& h) {
                               const auto lock = claim(h);
                               return h.stream->resumed();
                             })
      .def_property_readonly("warning",
                             [](StreamHandle& h) {
                               const auto lock = claim(h);
                               return h.stream->warning();
                             })
      .def_property_readonly("closed", [](const StreamHandle& h) { return h.stream == nullptr; })
      .def("push_file",
           [](StreamHandle& h, const std::string& path) {
             const auto lock = claim(h);
             std::ifstream file(path);
             if (!file) throw MissingInputError("cannot open WIM log '" + path + "'");
             return run(h, file, path);
           })
      .def("push_arrays",
           [](StreamHandle& h, const py::tuple& arrays, const SiteHandle& where, const std::string& source) {
             const auto lock = claim(h);
             std::istringstream text(log_text(records_of_tuple(arrays, where)));
             return run(h, text, source);
           })
      .def("close", [](StreamHandle& h) {
        std::unique_lock<std::mutex> lock(h.busy, std::try_to_lock);
        if (!lock.owns_lock())
          throw BusyError("the Stream on '" + h.state_dir + "' is in use by another thread's call");
        h.stream.reset();  // releases the state's lock
      });
  m.def("_open_stream", &open_stream, py::arg("site"), py::arg("state_dir"), py::arg("seed"),
        py::arg("options"));
}

}  // namespace ssrfleet::python
