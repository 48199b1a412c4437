// Hierarchical radiosity at scale (issue 9's target: RenderPark's hospital, hosp.mgf, in under
// 30 s on 2 cores and 1 GB): one whole solve (refinement, then gathers to the fixed point) of
// `hierarchical` on an MGF scene, one element per polygon, with links, leaves, rays and the peak
// resident memory as counters. The scene is RADLAB_BENCH_SCENE, else RenderPark's classroom
// (the hospital, 12,235 polygons after the loader's overlap repair, is ~4.4x classroom's root
// pairs without clustering; docs/solvers.md):
//   build/bench/bench_hierarchical --benchmark_counters_tabular=true
//   RADLAB_BENCH_SCENE=../shared/scenes/renderpark/hospital/hosp.mgf build/bench/bench_hierarchical
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

#include "formfactor/methods/raycast.h"
#include "scene/scene_loader.h"
#include "solvers/registry.h"

namespace radlab {
namespace {

double peak_rss_mb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

void BM_HierarchicalSolve(benchmark::State& state, double feps) {
  const char* env = std::getenv("RADLAB_BENCH_SCENE");
  const std::string path =
      env ? env
          : std::string(RADLAB_SOURCE_DIR) + "/../shared/scenes/renderpark/salon/classroom.mgf";
  LoadedScene loaded = load_scene(path);
  const Mesh mesh = build_mesh(loaded.scene, {1, 0.0});
  // The System's row source is never read by hierarchical (it evaluates its own factors).
  RaycastFormFactors rows(loaded.scene, mesh, RaycastOptions{});
  System system(loaded.scene, mesh, rows);
  std::map<std::string, double> stats;
  long long passes = 0;
  for (auto _ : state) {
    ParamBag bag("bench");
    bag.set("feps", std::to_string(feps));
    auto solver = make_solver("hierarchical", bag);
    solver->init(system);
    passes = 0;
    while (!solver->step().finished) ++passes;
    for (const auto& [k, v] : solver->statistics()) stats[k] = v;
  }
  state.counters["polygons"] = double(loaded.scene.polygons.size());
  state.counters["links"] = stats["links"];
  state.counters["leaves"] = stats["leaves"];
  state.counters["rays"] = stats["rays"];
  state.counters["row_evals"] = stats["pass1.row_evaluations"];
  state.counters["refine_s"] = stats["refinement_seconds"];
  state.counters["gather_s"] = stats["gather_seconds"];
  state.counters["passes"] = double(passes);
  state.counters["hierarchy_MB"] = stats["memory_bytes"] / 1e6;
  state.counters["peak_rss_MB"] = peak_rss_mb();
}

BENCHMARK_CAPTURE(BM_HierarchicalSolve, feps_0_08, 0.08)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_HierarchicalSolve, feps_0_04, 0.04)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
