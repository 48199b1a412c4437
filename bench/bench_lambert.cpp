// Lambert's point-to-polygon formula (formfactor/integrate/point_polygon.h): the scalar path, one
// point at a time (with the inline atan2 since 2026-11-27, libm's before), against the batched
// evaluator, all of a rule's points against one polygon in one call, on the inputs the raycast
// form factors give it.
//
// Inputs: the Cornell box at --subdiv 16 (5,120 elements, as bench_formfactors). For 64 rows
// spread over the mesh, every facing pair (i, j) whose fixed Gauss rule suffices (raycast's
// order rule: tolerance 1e-4, max_order 8, the same gap, diameter and grazing scale) gets that
// rule's points on element i (clipped to the part in front of j's plane) against element j: the
// mix of rule sizes (mostly 2x2 and 3x3) and of points needing clipping a raycast row sees.
// Argument `order`: 0 for that mix, or one fixed order for every pair (how the batch size pays).
//
// BM_LambertScalarVsBatched times both on the same pairs, interleaved (one pass of the scalar
// path, one of the batched, again), on the thread's CPU clock, and reports both rates in
// evaluations/s, their ratio, and the largest relative difference of the pairs' integrals.
// Argument `kernel`: 0 the best for this CPU (avx2 here), 1 the baseline (SSE2) build.
//
// Run: build/bench/bench_lambert --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <algorithm>
#include <span>

#include "bench/bench_clock.h"
#include "bench/bench_scenes.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/integrate/quadrature.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/visibility.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"

namespace radlab {
namespace {

// All pairs' inputs in contiguous arrays (as a row's are in cache: its rules are built once per
// order, its polygons are the mesh's), the points twice: as the scalar path takes them (array of
// structures) and as the batched path does (structure of arrays).
struct Pair {
  size_t first, count;           // points[first, first + count), x/y/z/weight likewise
  size_t first_corner, corners;  // to = corners[first_corner, first_corner + corners)
  Vec3 from_normal, to_normal;
};

struct Workload {
  std::vector<QuadraturePoint> points;
  std::vector<double> x, y, z, weight;
  std::vector<Vec3> corners;
  std::vector<Pair> pairs;
};

using bench::cornell;

// The pairs of 64 rows and their rules, as RaycastFormFactors::unoccluded chooses them (only the
// fixed-rule pairs: the adaptive ones use 3x3 rules on many small cells).
Workload make_workload(int fixed_order) {
  const Mesh& mesh = cornell().mesh;
  const RaycastFormFactors raycast(cornell().scene, mesh, {});
  const double eps = plane_epsilon(mesh);
  Workload w;
  std::vector<Vec3> from, to;
  std::vector<QuadraturePoint> points;
  for (size_t r = 0; r < 64; ++r) {
    const size_t i = (r * 7919) % mesh.size();
    for (size_t j = 0; j < mesh.size(); ++j) {
      if (j == i || !pair_faces(mesh, i, j, eps)) continue;
      const int order = raycast.fixed_order(i, j);
      if (order == 0) continue;
      mesh.corners(i, from);
      mesh.corners(j, to);
      clip_to_front(from, mesh.centroid[j], mesh.normal[j], eps);
      element_quadrature(from, fixed_order > 0 ? fixed_order : order, points);
      w.pairs.push_back({w.points.size(), points.size(), w.corners.size(), to.size(),
                         mesh.normal[i], mesh.normal[j]});
      for (const QuadraturePoint& q : points) {
        w.points.push_back(q);
        w.x.push_back(q.position.x);
        w.y.push_back(q.position.y);
        w.z.push_back(q.position.z);
        w.weight.push_back(q.weight);
      }
      w.corners.insert(w.corners.end(), to.begin(), to.end());
    }
  }
  return w;
}

void BM_LambertScalarVsBatched(benchmark::State& state) {
  const int fixed_order = int(state.range(0));
  const BatchKernel kernel = state.range(1) == 0 ? BatchKernel::kBest : BatchKernel::kBaseline;
  const Workload w = make_workload(fixed_order);
  std::vector<double> scalar(w.pairs.size()), batched(w.pairs.size()), values;
  std::vector<Vec3> scratch;
  double scalar_seconds = 0.0, batched_seconds = 0.0;
  size_t passes = 0;
  for (auto _ : state) {
    timespec start = thread_now();
    for (size_t p = 0; p < w.pairs.size(); ++p) {
      const Pair& pair = w.pairs[p];
      const std::span<const Vec3> to(w.corners.data() + pair.first_corner, pair.corners);
      double sum = 0.0;
      for (size_t k = pair.first; k < pair.first + pair.count; ++k)
        sum += w.points[k].weight * point_to_polygon_form_factor(w.points[k].position,
                                                                 pair.from_normal, to,
                                                                 pair.to_normal, scratch);
      scalar[p] = sum;
    }
    benchmark::DoNotOptimize(scalar.data());
    scalar_seconds += thread_seconds(start);
    start = thread_now();
    for (size_t p = 0; p < w.pairs.size(); ++p) {
      const Pair& pair = w.pairs[p];
      const std::span<const Vec3> to(w.corners.data() + pair.first_corner, pair.corners);
      const size_t first = pair.first, n = pair.count;
      values.resize(n);
      point_to_polygon_form_factors({w.x.data() + first, w.y.data() + first, w.z.data() + first, n},
                                    pair.from_normal, to, pair.to_normal, values.data(), scratch,
                                    kernel);
      double sum = 0.0;
      for (size_t k = 0; k < n; ++k) sum += w.weight[first + k] * values[k];
      batched[p] = sum;
    }
    benchmark::DoNotOptimize(batched.data());
    batched_seconds += thread_seconds(start);
    ++passes;
  }
  double worst = 0.0;
  for (size_t p = 0; p < w.pairs.size(); ++p)
    if (scalar[p] != 0.0) worst = std::max(worst, std::abs(batched[p] / scalar[p] - 1.0));
  const double evaluations = double(w.points.size()) * double(passes);
  state.counters["scalar evals/s"] = evaluations / scalar_seconds;
  state.counters["batched evals/s"] = evaluations / batched_seconds;
  state.counters["ratio"] = scalar_seconds / batched_seconds;
  state.counters["points/pair"] = double(w.points.size()) / double(w.pairs.size());
  state.counters["max rel diff"] = worst;
  state.SetLabel(batch_kernel_name(kernel));
}
BENCHMARK(BM_LambertScalarVsBatched)
    ->ArgNames({"order", "kernel"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({2, 0})
    ->Args({3, 0})
    ->Args({4, 0})
    ->Args({8, 0})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
