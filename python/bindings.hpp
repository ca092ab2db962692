// The compiled part of the Python module (ssrfleet._core): each file binds one topic. The package
// python/ssrfleet/ wraps it with keyword defaults, array checks and the DataFrame conversion.
#pragma once

#include <pybind11/pybind11.h>

namespace ssrfleet::python {

// An option given from Python as options[key]: None or absent leaves the command's default (false).
template <typename T>
bool take(const pybind11::dict& options, const char* key, T& value) {
  if (!options.contains(key) || options[key].is_none()) return false;
  value = options[key].template cast<T>();
  return true;
}

// The exception classes (ssrfleet.Error and its children) and the translation of the library's
// errors into them (errors.cpp).
void bind_errors(pybind11::module_& m);
// Roads, sites and simulate (sites.cpp).
void bind_sites(pybind11::module_& m);
// fit, the posterior, read_posterior and predict (posterior.cpp).
void bind_posterior(pybind11::module_& m);
// diagnose (diagnose.cpp).
void bind_diagnose(pybind11::module_& m);
// The stream over a state directory (stream.cpp).
void bind_stream(pybind11::module_& m);

}  // namespace ssrfleet::python
