// The convex-enclosure test of visibility set-up (formfactor/visibility/occlusion.h) on a closed
// box whose faces are split m x m (6 m^2 quads, every one facing in: convex, so no scan may stop
// early), against the pair-by-pair definition it replaced, which tested every vertex against
// every polygon's plane. BM_ConvexEnclosure/m and BM_ConvexEnclosureByDefinition/m; CPU time of
// the calling thread (bench_clock.h).
//
// Run: build/bench/bench_convex_enclosure --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include "bench/bench_clock.h"
#include "formfactor/visibility/occlusion.h"
#include "tests/formfactor/visibility/convex_by_definition.h"

namespace radlab {
namespace {

Scene tessellated_box(int m) {
  Scene scene;
  scene.materials.push_back(Material{"grey", Rgb(0.5), Rgb(0.0)});
  const Vec3 X(2, 0, 0), Y(0, 1, 0), Z(0, 0, 3), O(0.0);
  const Vec3 faces[6][3] = {{O, Z, X},     {O + Y, X, Z}, {O, X, Y},
                            {O + Z, Y, X}, {O, Y, Z},     {O + X, Z, Y}};
  for (const auto& [o, u, v] : faces)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) {
        auto at = [&](double a, double b) { return o + u * (a / m) + v * (b / m); };
        scene.polygons.push_back(
            Polygon{{at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)}, 0, "box"});
      }
  return scene;
}

bool by_definition(const Scene& scene) {
  return convex_by_definition(scene);
}

template <bool (*Test)(const Scene&)>
void run(benchmark::State& state) {
  const Scene scene = tessellated_box(int(state.range(0)));
  for (auto _ : state) {
    const timespec start = thread_now();
    const bool convex = Test(scene);
    state.SetIterationTime(thread_seconds(start));
    if (!convex) state.SkipWithError("the tessellated box must be convex");
  }
  state.counters["polygons"] = double(scene.polygons.size());
}

bool current(const Scene& scene) {
  return is_convex_enclosure(scene);
}

void BM_ConvexEnclosure(benchmark::State& state) {
  run<current>(state);
}
void BM_ConvexEnclosureByDefinition(benchmark::State& state) {
  run<by_definition>(state);
}

BENCHMARK(BM_ConvexEnclosure)->Arg(20)->Arg(80)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ConvexEnclosureByDefinition)
    ->Arg(20)
    ->Arg(80)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
