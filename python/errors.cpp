// The library's errors as Python exceptions. Each class derives from ssrfleet.Error and from the
// built-in exception a Python user would catch for it (a bad value is a ValueError, a missing file
// a FileNotFoundError), so `except ValueError` works as well as `except ssrfleet.DataError`.
// A DataError keeps where the data was wrong: attributes file, line, field and reason.
#include <exception>
#include <stdexcept>

#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "util/errors.hpp"
#include "util/stop_token.hpp"

namespace py = pybind11;

namespace ssrfleet::python {

namespace {
// The classes live as long as the interpreter (a module's exception types are never unloaded).
PyObject* g_error = nullptr;
PyObject* g_usage = nullptr;
PyObject* g_data = nullptr;
PyObject* g_missing = nullptr;
PyObject* g_io = nullptr;
PyObject* g_busy = nullptr;
PyObject* g_numerical = nullptr;

PyObject* new_class(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  const std::string qualified = std::string("ssrfleet.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(type));  // add_object steals nothing: the module holds its own reference
  return type;
}

void raise_data_error(const DataError& e) {
  py::object instance = py::reinterpret_steal<py::object>(PyObject_CallFunction(g_data, "s", e.what()));
  if (!instance) throw py::error_already_set();
  instance.attr("file") = e.file();
  instance.attr("line") = e.line();
  instance.attr("field") = e.field();
  instance.attr("reason") = e.reason();
  PyErr_SetObject(g_data, instance.ptr());
}
}  // namespace

void bind_errors(py::module_& m) {
  py::handle exception(PyExc_Exception);
  g_error =
      new_class(m, "Error", py::make_tuple(exception), "Every error ssrfleet raises derives from this.");
  py::handle base(g_error);
  g_usage = new_class(m, "UsageError", py::make_tuple(base, py::handle(PyExc_ValueError)),
                      "A bad argument value or a bad combination of arguments.");
  g_data =
      new_class(m, "DataError", py::make_tuple(base, py::handle(PyExc_ValueError)),
                "Input data that is malformed or physically impossible. Attributes: file, line (0 when the "
                "format has no lines), field, reason.");
  g_missing = new_class(m, "MissingInputError", py::make_tuple(base, py::handle(PyExc_FileNotFoundError)),
                        "An input file that does not exist or cannot be opened.");
  g_io =
      new_class(m, "IoError", py::make_tuple(base, py::handle(PyExc_OSError)), "Writing an output failed.");
  g_busy = new_class(m, "BusyError", py::make_tuple(base, py::handle(PyExc_RuntimeError)),
                     "A resource another process holds (a stream state in use): try again later.");
  g_numerical = new_class(m, "NumericalError", py::make_tuple(base, py::handle(PyExc_ArithmeticError)),
                          "A numerical failure inside a computation (all weights zero, a NaN likelihood).");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const DataError& e) {
      raise_data_error(e);
    } catch (const UsageError& e) {
      PyErr_SetString(g_usage, e.what());
    } catch (const MissingInputError& e) {
      PyErr_SetString(g_missing, e.what());
    } catch (const IoError& e) {
      PyErr_SetString(g_io, e.what());
    } catch (const BusyError& e) {
      PyErr_SetString(g_busy, e.what());
    } catch (const NumericalError& e) {
      PyErr_SetString(g_numerical, e.what());
    } catch (const util::Stopped&) {
      // Only a call whose token was tripped stops, and the module trips one on a signal: the
      // signal's own exception is raised then (stoppable.hpp); this is the fallback.
      PyErr_SetNone(PyExc_KeyboardInterrupt);
    }
  });
}

}  // namespace ssrfleet::python
