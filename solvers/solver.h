// The one interface every solver implements (DESIGN §4). A solver computes; the runner measures:
// it times step(), decides when to evaluate metrics, and writes the trace. init() and step() do
// the work; solution() and display() only expose state.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/radiosity.h"
#include "solvers/system.h"

namespace radlab {

struct StepInfo {
  // True when the solver has nothing left to do: e.g. no unshot energy anywhere, so further
  // steps would not change the solution. The runner stops.
  bool finished = false;
};

class Solver {
 public:
  virtual ~Solver() = default;

  // Prepares the solver for `system`, which outlives it and does not change during the run.
  virtual void init(const System& system) = 0;
  // One unit of work: usually one form-factor row (a gather at one element, one shot).
  virtual StepInfo step() = 0;
  // The estimate whose error is measured: converges to the reference.
  virtual const Radiosity& solution() const = 0;
  // What a user would see mid-run (e.g. solution plus an ambient term). Defaults to solution().
  virtual Radiosity display() const { return solution(); }
  // Unshot radiosity dB for shooting methods (null for gathering methods).
  virtual const Radiosity* unshot() const { return nullptr; }
};

}  // namespace radlab
