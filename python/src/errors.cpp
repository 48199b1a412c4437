// radlab's errors as Python exceptions. Each radlab::Error becomes radlab.Error or the subclass
// of its exit-code class, carrying radlab's message verbatim and the exit code the command line
// would return (`exit_code`: 2 usage, 3 invalid input, 4 numerical failure, 5 tolerance not
// reached), so a script can tell a wrong call from a bad scene from a failed computation.
#include <pybind11/pybind11.h>

#include "core/error.h"
#include "python/src/bindings.h"

namespace py = pybind11;

namespace radlab::python {
namespace {

// The exception types, created once in the module (never destroyed: they live as long as the
// interpreter, and a static py::object must not be released after it is finalised).
PyObject* g_error = nullptr;
PyObject* g_usage = nullptr;
PyObject* g_input = nullptr;
PyObject* g_numerical = nullptr;
PyObject* g_tolerance = nullptr;

PyObject* make_type(py::module_& m, const char* name, PyObject* base, int exit_code,
                    const char* doc) {
  const std::string qualified = std::string("radlab.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, base, nullptr);
  if (!type) throw py::error_already_set();
  py::handle handle(type);
  handle.attr("exit_code") = exit_code;
  m.attr(name) = handle;
  return type;
}

PyObject* type_of(ExitCode code) {
  switch (code) {
    case ExitCode::kUsage:
      return g_usage;
    case ExitCode::kInvalidInput:
      return g_input;
    case ExitCode::kNumerical:
      return g_numerical;
    case ExitCode::kToleranceNotReached:
      return g_tolerance;
    default:
      return g_error;
  }
}

}  // namespace

void bind_errors(py::module_& m) {
  g_error = make_type(m, "Error", PyExc_RuntimeError, 1,
                      "A radlab error; `exit_code` is what `radlab` would exit with.");
  g_usage = make_type(m, "UsageError", g_error, 2,
                      "Called wrongly: unknown solver, method, scene or key, or a value out of "
                      "range (exit code 2).");
  g_input = make_type(m, "InputError", g_error, 3,
                      "Invalid input: a malformed or impossible scene, an unreadable or "
                      "unwritable file (exit code 3).");
  g_numerical = make_type(m, "NumericalError", g_error, 4,
                          "The numbers went wrong: no finite solution, divergence, a failed "
                          "certificate (exit code 4).");
  g_tolerance = make_type(m, "ToleranceNotReached", g_error, 5,
                          "The run ended before the tolerance asked for (exit code 5).");
  py::register_exception_translator([](std::exception_ptr thrown) {
    try {
      if (thrown) std::rethrow_exception(thrown);
    } catch (const Interrupted&) {
      PyErr_SetNone(PyExc_KeyboardInterrupt);  // Ctrl-C during long work (bindings.h LongWork)
    } catch (PythonError& e) {
      e.error().restore();  // a Python solver's own exception, raised again as it was
    } catch (const Error& e) {
      PyErr_SetString(type_of(e.code()), e.what());
    }
  });
}

}  // namespace radlab::python
