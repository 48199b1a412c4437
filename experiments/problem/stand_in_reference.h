// The uncertified stand-in reference for scenes too large for the certified one (n^2 form
// factors): a much finer hierarchical radiosity run (solvers/hierarchical*.h) projected on the
// run's mesh, labelled kind = "hierarchical-fine" in trace.csv and run.json. It is NOT a
// certificate: it carries no bound, and its error against the true solution of the mesh's system
// is that of a hierarchical run (docs/solvers.md, "hierarchical"); it only shows how a run
// converges towards a finer discretisation of the same scene.
#pragma once

#include "solvers/reference/reference.h"
#include "solvers/system.h"

namespace radlab {

inline constexpr const char* kHierarchicalFineReference = "hierarchical-fine";

// Runs `hierarchical` with feps and aeps (fractions as in its parameters) to its fixed point on
// `system` and returns its projected solution as a Reference of kind "hierarchical-fine".
Reference hierarchical_fine_reference(const System& system, double feps, double aeps);

}  // namespace radlab
