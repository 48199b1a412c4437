// The extension module `_radlab`: radlab's scenes, form factors, references and runs for the
// Python package python/radlab/ (docs/python.md). Everything user-facing (numpy, scipy.sparse,
// pandas, argument checks in Python terms) is in the package; this module is the thin layer
// over the C++ library, built on the same calls the command line makes (RunRequest,
// execute_run), so the two cannot drift.
#include <pybind11/pybind11.h>

#include "core/version.h"
#include "python/src/bindings.h"

PYBIND11_MODULE(_radlab, m) {
  m.doc() = "radlab's C++ library (use the package `radlab`, docs/python.md)";
  m.attr("__version__") = radlab::kVersion;
  radlab::python::bind_errors(m);
  radlab::python::bind_scene(m);
  radlab::python::bind_run(m);
  radlab::python::bind_python_solver(m);
}
