// Loading a tessellated floor (issue 36.3): a 1 m grid of m x m squares in the plane z = 0, each
// split into two triangles, written as an OBJ and loaded by load_scene (read, validate, the
// coincidence repair). Every triangle lies on one plane, so the repair's all-pairs loop over a
// plane compared each with every earlier one (10,000 triangles: 67.7 s in the issue); with the
// R-tree of bounding boxes (scene/overlap.cpp) each meets only its grid neighbours.
// BM_LoadTessellatedFloor/m: 2 m^2 triangles (m = 71: 10,082; m = 316: 199,712), CPU time of the
// loading thread (bench_clock.h), triangles_per_s.
//
// Run: build/bench/bench_loading --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "bench/bench_clock.h"
#include "scene/scene_loader.h"

namespace radlab {
namespace {

// The floor as an OBJ in the system's temporary folder (removed again); its path.
std::string write_floor(int m) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("radlab_bench_floor_" + std::to_string(m) + ".obj");
  std::ofstream out(path);
  out << "mtllib floor.mtl\n";
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i <= m; ++i) out << "v " << i << ' ' << j << " 0\n";
  out << "usemtl grey\n";
  auto index = [m](int i, int j) { return j * (m + 1) + i + 1; };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      out << "f " << index(i, j) << ' ' << index(i + 1, j) << ' ' << index(i + 1, j + 1) << '\n';
      out << "f " << index(i, j) << ' ' << index(i + 1, j + 1) << ' ' << index(i, j + 1) << '\n';
    }
  std::ofstream(path.parent_path() / "floor.mtl") << "newmtl grey\nKd 0.5 0.5 0.5\n";
  return path.string();
}

void BM_LoadTessellatedFloor(benchmark::State& state) {
  const int m = int(state.range(0));
  const std::string path = write_floor(m);
  size_t polygons = 0;
  for (auto _ : state) {
    const timespec start = thread_now();
    LoadedScene loaded = load_scene(path, false);
    state.SetIterationTime(thread_seconds(start));
    polygons = loaded.scene.polygons.size();
    benchmark::DoNotOptimize(loaded);
  }
  std::filesystem::remove(path);
  state.counters["triangles"] = double(2 * m * m);
  state.counters["kept"] = double(polygons);
  state.counters["triangles_per_s"] =
      benchmark::Counter(double(2 * m * m), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_LoadTessellatedFloor)
    ->Arg(71)
    ->Arg(316)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
