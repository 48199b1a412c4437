// Ray throughput of the Monte Carlo solvers against raw Embree (issue 32's target: a stochastic
// Jacobi step casts rays at >= 0.8 of raw Embree single-ray throughput on the same scene and core).
//
// Scenes: the Cornell box at --subdiv 16 (5,120 elements, bench_scenes.h), where the step was
// tuned, and builtin:office at --subdiv 4 (7,008 elements, two furnished cubicles: many small
// occluders), where it was not (BM_.../cornell and BM_.../office). One thread (TBB limited
// to one), CPU time of this thread (bench_clock.h). Each iteration, interleaved so the machine's
// drift cancels in the ratios:
//   - one step of stochastic-jacobi with 2^17 rays (the whole step: the power distribution over
//     the elements, the numbers, sampling points and cosine directions, Embree's closest hits and
//     the deposits), rays counted by the System;
//   - the same number of raw single rays: EmbreeScene::intersect (rtcIntersect1) on origins and
//     directions drawn beforehand from the same distribution (an element chosen by the power the
//     regular steps propagate, a uniform point on it, a cosine direction), outside the timing:
//     Embree's own cost, nothing else;
//   - the same raw rays again, ordered by their source element as a step orders its rays (it
//     sorts each block's rays by the number that picks the source, power_propagation.cpp):
//     Embree alone on the step's order, to tell how much of the step's speed is the order's;
//   - the same sorted rays through Embree's stream call (EmbreeScene::intersect_stream,
//     rtcIntersect1M, incoherent), the call the step makes: Embree alone on the step's order
//     and API;
//   - one step of random-walk (shooting walks, collision estimator) of 2^15 walks, rays counted
//     by the System.
// Counters: sj_rays_per_s, embree_rays_per_s, embree_sorted_rays_per_s,
// embree_stream_sorted_rays_per_s, rw_rays_per_s, and the ratios sj_vs_embree (issue 32's
// target), sj_vs_embree_sorted, sj_vs_embree_stream_sorted and rw_vs_embree.
//
// Run: build/bench/bench_monte_carlo --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "bench/bench_clock.h"
#include "bench/bench_scenes.h"
#include "core/param_bag.h"
#include "core/random.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/embree_scene.h"
#include "solvers/monte_carlo/ray_sampler.h"
#include "solvers/registry.h"
#include "solvers/system.h"

namespace radlab {
namespace {

constexpr uint64_t kRays = uint64_t(1) << 17;

std::unique_ptr<Solver> make(const char* name, std::vector<std::string> params) {
  ParamBag bag = ParamBag::from_assignments(params, name);
  return make_solver(name, bag);
}

struct RawRays {
  std::vector<Vec3> origin, direction;
  std::vector<size_t> element;  // the source's
};

// The same rays ordered by source element (ties in draw order).
RawRays by_source(const RawRays& raw) {
  std::vector<size_t> order(raw.origin.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return raw.element[a] < raw.element[b]; });
  RawRays sorted;
  for (size_t k : order) {
    sorted.origin.push_back(raw.origin[k]);
    sorted.direction.push_back(raw.direction[k]);
    sorted.element.push_back(raw.element[k]);
  }
  return sorted;
}

// kRays rays as a regular stochastic-jacobi step draws them: elements by power A_i sum_c |B_ic|
// (most rays leave the lamp and the lit walls), a uniform point, a cosine direction.
RawRays raw_rays(const Mesh& mesh, const Radiosity& B) {
  std::vector<double> cumulative(mesh.size());
  double total = 0.0;
  for (size_t i = 0; i < mesh.size(); ++i) {
    double b = 0.0;
    for (int c = 0; c < B.channels(); ++c) b += std::abs(B.at(c, i));
    cumulative[i] = total += mesh.area[i] * b;
  }
  Pcg32 rng(42);
  RawRays r;
  for (uint64_t k = 0; k < kRays; ++k) {
    const double target = rng.next_double() * total;
    const size_t i =
        size_t(std::upper_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin());
    const size_t e = std::min(i, mesh.size() - 1);
    const double u1 = rng.next_double(), u2 = rng.next_double();
    const double u3 = rng.next_double(), u4 = rng.next_double();
    r.element.push_back(e);
    r.origin.push_back(monte_carlo::point_on_element(mesh, e, u1, u2));
    r.direction.push_back(monte_carlo::cosine_direction(mesh.normal[e], u3, u4));
  }
  return r;
}

void BM_StochasticJacobiAgainstRawEmbree(benchmark::State& state,
                                         const bench::SceneMesh& (*scene)()) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const bench::SceneMesh& c = scene();
  const RaycastFormFactors unused_rows(c.scene, c.mesh, RaycastOptions{});  // never read
  const System system(c.scene, c.mesh, unused_rows);
  auto jacobi = make("stochastic-jacobi", {"rays=" + std::to_string(kRays)});
  auto walks = make("random-walk", {"paths=" + std::to_string(kRays / 4)});
  jacobi->init(system);
  walks->init(system);
  // Past the incremental steps (8 on the box), untimed: the timed steps are regular ones.
  for (int k = 0; k < 12; ++k) jacobi->step();
  const RawRays raw = raw_rays(c.mesh, jacobi->solution());
  const RawRays sorted = by_source(raw);
  // As the solvers' (element_rays.cpp): a millionth of the scene's bounding diagonal.
  Vec3 low(1e300), high(-1e300);
  for (const Vec3& v : c.mesh.vertices) low = glm::min(low, v), high = glm::max(high, v);
  const double t_near = 1e-6 * glm::length(high - low);
  double sj_seconds = 0.0, embree_seconds = 0.0, sorted_seconds = 0.0, stream_seconds = 0.0;
  double rw_seconds = 0.0;
  std::vector<RayHit> stream_hits(kRays);
  uint64_t sj_rays = 0, embree_rays = 0, rw_rays = 0, hits = 0;
  for (auto _ : state) {
    uint64_t before = system.rays_used();
    timespec start = thread_now();
    jacobi->step();
    sj_seconds += thread_seconds(start);
    sj_rays += system.rays_used() - before;

    start = thread_now();
    for (uint64_t k = 0; k < kRays; ++k)
      hits += c.embree->intersect(raw.origin[k], raw.direction[k], t_near, 1e30).hit ? 1 : 0;
    embree_seconds += thread_seconds(start);
    embree_rays += kRays;

    start = thread_now();
    for (uint64_t k = 0; k < kRays; ++k)
      hits += c.embree->intersect(sorted.origin[k], sorted.direction[k], t_near, 1e30).hit ? 1 : 0;
    sorted_seconds += thread_seconds(start);

    start = thread_now();
    c.embree->intersect_stream(sorted.origin.data(), sorted.direction.data(), kRays, t_near, 1e30,
                               stream_hits.data());
    stream_seconds += thread_seconds(start);
    hits += stream_hits[kRays / 2].hit ? 1 : 0;

    before = system.rays_used();
    start = thread_now();
    walks->step();
    rw_seconds += thread_seconds(start);
    rw_rays += system.rays_used() - before;
  }
  benchmark::DoNotOptimize(hits);
  const double sj = double(sj_rays) / sj_seconds, embree = double(embree_rays) / embree_seconds;
  const double rw = double(rw_rays) / rw_seconds;
  const double embree_sorted = double(embree_rays) / sorted_seconds;
  const double embree_stream = double(embree_rays) / stream_seconds;
  state.counters["sj_rays_per_s"] = sj;
  state.counters["embree_rays_per_s"] = embree;
  state.counters["rw_rays_per_s"] = rw;
  state.counters["embree_sorted_rays_per_s"] = embree_sorted;
  state.counters["sj_vs_embree"] = sj / embree;
  state.counters["embree_stream_sorted_rays_per_s"] = embree_stream;
  state.counters["sj_vs_embree_sorted"] = sj / embree_sorted;
  state.counters["sj_vs_embree_stream_sorted"] = sj / embree_stream;
  state.counters["rw_vs_embree"] = rw / embree;
}
BENCHMARK_CAPTURE(BM_StochasticJacobiAgainstRawEmbree, cornell, &bench::cornell)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);
BENCHMARK_CAPTURE(BM_StochasticJacobiAgainstRawEmbree, office, &bench::office_traced)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
