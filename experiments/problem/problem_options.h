// What a front end asks for when it names a problem (the command line's --subdiv, --ff, ...; the
// Python module's keyword arguments), and the one function that turns it into a ProblemSpec, so
// that the front ends cannot drift apart in what they accept or how they read it.
#pragma once

#include <string>
#include <vector>

#include "experiments/problem/problem.h"

namespace radlab {

struct SceneOptions {
  std::string scene;
  int subdiv = 1;
  double element_size = 0.0;
  std::string patches = "elements";  // --patches: two levels (solvers/two_level/patches.h)
  double patch_size = 0.0;           // --patch-size, with --patches size
  std::string patch_rows = "auto";   // --patch-rows: centre | mean (solvers/two_level/patch_rows.h)
  bool keep_overlaps = false;        // --keep-overlaps: coincident polygons as they are (overlap.h)
};

struct FormFactorOptions {
  std::string method = kDefaultFormFactorMethod;
  std::vector<std::string> set;
  std::string precision = "float";  // float | double
  std::string mode = "cached";      // cached | on-the-fly
};

// The spec of these options; UsageError for a subdivision below 1, an element size that is
// negative or not finite, or patch options that contradict each other.
ProblemSpec make_problem_spec(const SceneOptions& scene, const FormFactorOptions& ff);

}  // namespace radlab
