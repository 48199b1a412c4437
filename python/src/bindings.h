// The parts of the extension module `_radlab` (python/src/module.cpp), each binding one area of
// radlab. The Python package python/radlab/ wraps them in the documented API (docs/python.md).
#pragma once

#include <pybind11/pybind11.h>

#include <csignal>
#include <utility>

#include "core/error.h"
#include "core/interrupt.h"

namespace radlab::python {

// A Python exception raised inside a Python solver's call (or a pybind11 TypeError / ValueError
// raised while its result is read), carried through radlab's runner as a radlab::Error: the
// runner lets radlab errors through unchanged (experiments/run/runner.h, call_solver) instead of
// turning them into a NumericalError, a sweep records it as that run's failure with its message,
// and when the run returns to Python the original exception is raised again, type and traceback
// intact (errors.cpp). Exit code 4 (the solver failed), as for any solver's exception.
class PythonError : public Error {
 public:
  explicit PythonError(pybind11::error_already_set error)
      : Error(ExitCode::kNumerical, error.what()), error_(std::move(error)) {}
  pybind11::error_already_set& error() { return error_; }

 private:
  pybind11::error_already_set error_;
};

// Long C++ work called from Python: the GIL released, and Ctrl-C (SIGINT) turned into an
// interrupt request that the work checks where it reports progress (core/interrupt.h), which
// unwinds it as radlab::Interrupted and reaches Python as KeyboardInterrupt (errors.cpp).
// Python's own handler is restored afterwards; a SIGINT the work did not get to is raised again
// for it, so none is lost.
class LongWork {
 public:
  LongWork() {
    clear_interrupt();
    previous_ = std::signal(SIGINT, &on_sigint);
  }
  ~LongWork() {
    std::signal(SIGINT, previous_ == SIG_ERR ? SIG_DFL : previous_);
    if (interrupt_requested()) {
      clear_interrupt();
      std::raise(SIGINT);  // to Python's handler: KeyboardInterrupt at its next check
    }
  }
  LongWork(const LongWork&) = delete;
  LongWork& operator=(const LongWork&) = delete;

 private:
  static void on_sigint(int) { request_interrupt(); }
  void (*previous_)(int) = SIG_DFL;
  pybind11::gil_scoped_release release_;  // after the handler is installed, before it is restored
};

// Calls `f` (into Python, with the GIL held) so that what Python raises leaves as a PythonError.
template <class F>
auto keep_python_errors(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (pybind11::error_already_set& e) {
    throw PythonError(std::move(e));
  } catch (const pybind11::builtin_exception& e) {
    e.set_error();  // the Python exception it stands for, then fetched
    throw PythonError(pybind11::error_already_set());
  }
}

void bind_errors(pybind11::module_& m);
void bind_scene(pybind11::module_& m);
void bind_run(pybind11::module_& m);
void bind_python_solver(pybind11::module_& m);

}  // namespace radlab::python
