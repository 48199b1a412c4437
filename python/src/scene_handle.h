// A scene loaded from Python: its ProblemSpec (the command line's scene and form-factor options),
// the scene and mesh as loaded, and the problems prepared on it for runs (matrix, certified
// reference), each prepared once and shared by every later call, as a sweep's runs share theirs.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "experiments/problem/problem.h"
#include "experiments/run/run_request.h"

namespace radlab::python {

class SceneHandle {
 public:
  // Loads and meshes (no matrix yet). Call without the GIL.
  explicit SceneHandle(const ProblemSpec& spec);

  const ProblemSpec& spec() const { return spec_; }
  // The scene and mesh (rows on the fly, no matrix, no reference).
  const Problem& loaded() const { return *loaded_; }
  // The problem a run with this reference choice and budget runs on (prepare_run_problem, the
  // command line's preparation), prepared on first use. Call without the GIL.
  const Problem& run_problem(const ReferenceChoice& reference, const Budget& budget);

 private:
  ProblemSpec spec_;
  std::unique_ptr<Problem> loaded_;
  std::map<std::string, std::unique_ptr<Problem>> prepared_;
};

}  // namespace radlab::python
