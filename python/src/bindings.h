// The parts of the extension module `_radlab` (python/src/module.cpp), each binding one area of
// radlab. The Python package python/radlab/ wraps them in the documented API (docs/python.md).
#pragma once

#include <pybind11/pybind11.h>

namespace radlab::python {

void bind_errors(pybind11::module_& m);
void bind_scene(pybind11::module_& m);
void bind_run(pybind11::module_& m);
void bind_python_solver(pybind11::module_& m);

}  // namespace radlab::python
