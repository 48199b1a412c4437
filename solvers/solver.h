// The one interface every solver implements (DESIGN §4). A solver computes; the runner measures:
// it times step(), decides when to evaluate metrics, and writes the trace. init() and step() do
// the work; solution() and display() only expose state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/radiosity.h"
#include "solvers/system.h"

namespace radlab {

struct StepInfo {
  // True when the solver has nothing left to do: e.g. no unshot energy anywhere, so further
  // steps would not change the solution. The runner stops.
  bool finished = false;
};

// Wu & Wang 2002's coverage of each element by the shots of the current shooting session (their
// Figs. 2 and 4 plot p-error against it). Views into the solver's arrays: valid as long as the
// solver, the values change with every step.
struct ShotCoverage {
  std::span<const double> form_factor_sum;  // dff_j = sum of F_ji over this session's shooters i
  std::span<const uint8_t> shot;            // 1 where element j shot in this session
  long long session = 0;                    // shooting sessions started so far (1 = the first)
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
  // Per-element shot coverage for solvers that track it (interleaved); null otherwise.
  virtual const ShotCoverage* shot_coverage() const { return nullptr; }
  // How many unknowns the solver itself holds when that is not the evaluation mesh (hierarchy
  // leaves, adaptively split elements); 0 means "the mesh's elements". trace.csv writes it as
  // solver_elements, so a change in it marks a change of the solver's mesh.
  virtual size_t solver_elements() const { return 0; }
  // Solver-specific statistics (e.g. hierarchical radiosity's nodes, links, rays, per pass), as
  // key/value pairs in a stable order: written to run.json and printed at the end of `radlab
  // solve`. Empty for most solvers.
  virtual std::vector<std::pair<std::string, double>> statistics() const { return {}; }
};

}  // namespace radlab
