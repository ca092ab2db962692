// ssrfleet._core: the library behind `import ssrfleet` (docs/python.md).
#include <pybind11/pybind11.h>

#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "ssrfleet's library: roads, sites, simulate, fit, posteriors, SSR prediction, diagnose and streams (docs/python.md)";
  m.attr("__version__") = SSRFLEET_VERSION;
  ssrfleet::python::bind_errors(m);
  ssrfleet::python::bind_sites(m);
  ssrfleet::python::bind_posterior(m);
  ssrfleet::python::bind_diagnose(m);
  ssrfleet::python::bind_stream(m);
}
