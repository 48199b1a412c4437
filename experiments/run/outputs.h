// Files a run writes besides the trace: the per-element radiosity CSV and run.json.
#pragma once

#include <string>
#include <vector>

#include "core/json.h"
#include "core/radiosity.h"
#include "experiments/problem/problem.h"
#include "experiments/run/runner.h"

namespace radlab {

// CSV `element,area,B_r,B_g,B_b` (grey fields repeat their one channel), element ids in input
// order.
void write_radiosity_csv(const std::string& path, const Mesh& mesh, const Radiosity& B);

// The git revision this binary was built from ("-dirty" when tracked files differed), written
// at build time by cmake/GitSha.cmake.
const char* build_git_sha();

// Facts about the build and the machine: git SHA, form-factor source hash, compiler, build
// type, threads.
void write_build_info(JsonWriter& json);

// Everything about the problem: scene, mesh, form factors, what was left out, reference.
void write_problem_info(JsonWriter& json, const Problem& problem);

// Solver name and every option, defaults included ("resolved").
void write_solver_info(JsonWriter& json, const std::string& solver,
                       const std::map<std::string, std::string>& given);

void write_run_result(JsonWriter& json, const Budget& budget, const RunResult& result);

// A run's statistics (RunOutcome::statistics: Solver::statistics(), e.g. hierarchical radiosity's
// Table 1, and adaptive-shooting's final system on two levels) as the object "solver_statistics";
// nothing when there are none.
void write_solver_statistics(JsonWriter& json,
                             const std::vector<std::pair<std::string, double>>& statistics);

// The command line, quoted, for run.json.
std::string command_line(int argc, char** argv);

}  // namespace radlab
