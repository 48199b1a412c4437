// An experiment file (experiments/*.toml): scenes x meshes x seeds x solvers x solver-parameter
// axes, one budget and checkpoint schedule, form-factor method and mode, images to save.
// Unknown keys and wrong types are InputErrors naming file:line (docs/experiments.md documents
// every key).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "experiments/problem/problem.h"
#include "experiments/run/runner.h"

namespace radlab {

struct SolverSweep {
  std::string name;
  // key -> values; a key with several values is an axis of the Cartesian product.
  std::map<std::string, std::vector<std::string>> parameters;
};

struct ImageSpec {
  std::vector<long long> steps;  // checkpoints to save images at (empty: no images)
  int width = 256;
  int height = 256;
  bool error_maps = true;  // Cohen pseudo-colour and signed p-error maps beside each image
  bool smooth = true;      // radiosity images Gouraud-shaded (shading = "gouraud") or flat
                           // (shading = "flat": each element its own value); error maps are flat
};

struct ExperimentSpec {
  std::string path;  // the file it came from
  std::string name;
  std::string description;
  std::vector<std::string> scenes;
  std::vector<MeshOptions> meshes;
  std::vector<SolverSweep> solvers;
  std::string ff_method = kDefaultFormFactorMethod;
  std::map<std::string, std::string> ff_parameters;  // fixed method parameters (not the seed)
  std::vector<long long> seeds;  // form-factor seeds; empty: the method's default
  // Solver seeds (`solver_seeds = [...]`, or `repeats = K` for 0..K-1): every run is repeated
  // once per seed, which reaches the solver as its `seed` parameter. Runs differing only in it
  // are repeats of one configuration (aggregate.csv: experiments/run/seed_aggregate.h).
  std::vector<long long> solver_seeds;
  Precision precision = Precision::kFloat;
  RowMode row_mode = RowMode::kCached;
  PatchOptions patches;  // [patches]: two levels (solvers/two_level/patches.h)
  Budget budget;
  CheckpointSchedule schedule;
  ImageSpec images;
  // Steps at which solvers that track Wu & Wang's shot coverage (interleaved) write per-element
  // coverage and p-error (coverage/*.csv; Figs 2 and 4 of their paper).
  std::vector<long long> coverage_steps;
};

ExperimentSpec read_experiment(const std::string& path);

// One run of the sweep, in the sweep's fixed order.
struct PlannedRun {
  size_t index = 0;    // position in the full sweep (shards take index % N == i)
  size_t problem = 0;  // index into plan_problems()
  std::string solver;
  std::map<std::string, std::string> parameters;
  std::string run_id;  // spells its parameters: solver/scene:NAME[/subdiv:K][/seed:S]/k:v...
  // The run id without the solver's `seed` parameter: what its repeats over seeds share.
  std::string configuration;
};

struct PlannedProblem {
  ProblemSpec spec;
  std::string label;  // e.g. "scene:cornell/subdiv:6"
};

struct SweepPlan {
  std::vector<PlannedProblem> problems;
  std::vector<PlannedRun> runs;
};

SweepPlan plan_sweep(const ExperimentSpec& spec);

// The one run-id format of `radlab run` and `radlab solve`:
// solver/scene:NAME[/subdiv:K][/seed:S]/k:v... where NAME is a builtin's spec after "builtin:"
// or a scene file's stem, `problem_label` is "scene:NAME..." and the parameters are as given.
std::string scene_label(const std::string& scene);
std::string make_run_id(const std::string& solver, const std::string& problem_label,
                        const std::map<std::string, std::string>& parameters);
// make_run_id without the `seed` parameter: the configuration a run over one seed repeats.
std::string make_configuration(const std::string& solver, const std::string& problem_label,
                               std::map<std::string, std::string> parameters);

}  // namespace radlab
