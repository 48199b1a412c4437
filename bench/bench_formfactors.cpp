// Form-factor speed on the Cornell box (~5,000 elements, subdiv 16):
// - raw Embree occlusion rays/s for segments between random points on random elements, singly
//   (rtcOccluded1) and in coherent packets of 16 between two elements (rtcOccluded16), the pattern
//   the raycast method uses;
// - the visibility rays/s the raycast form factors achieve while computing whole rows (rays
//   divided by the full row time, quadrature included) — target >= 0.6 of the raw packet rate;
// - the dense matrix build on all cores.
// Quote the ratios measured in one run; absolute times on this machine are noisy.
#include <benchmark/benchmark.h>

#include <memory>

#include "core/random.h"
#include "formfactor/embree_scene.h"
#include "formfactor/matrix.h"
#include "formfactor/raycast.h"
#include "formfactor/sampling.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"

namespace radlab {
namespace {

struct Cornell {
  Scene scene;
  Mesh mesh;
  std::unique_ptr<EmbreeScene> embree;
};

const Cornell& cornell() {
  static const Cornell* c = [] {
    auto* result = new Cornell;
    result->scene = make_builtin_scene("cornell");
    validate_scene(result->scene);
    result->mesh = build_mesh(result->scene, {16, 0.0});
    result->embree = std::make_unique<EmbreeScene>(result->mesh);
    return result;
  }();
  return *c;
}

Vec3 random_point(const Mesh& mesh, Pcg32& rng, std::vector<Vec3>& corners,
                  std::vector<Vec3>& points) {
  mesh.corners(rng.next_below(uint32_t(mesh.size())), corners);
  stratified_points(corners, 1, rng, points);
  return points[0];
}

void BM_RawEmbreeOcclusionSingle(benchmark::State& state) {
  const Cornell& c = cornell();
  Pcg32 rng(7);
  std::vector<Vec3> corners, points;
  // Pre-generate segments so the loop times Embree alone.
  std::vector<std::pair<Vec3, Vec3>> segments(1 << 16);
  for (auto& s : segments)
    s = {random_point(c.mesh, rng, corners, points), random_point(c.mesh, rng, corners, points)};
  size_t k = 0, rays = 0, blocked = 0;
  for (auto _ : state) {
    const auto& [a, b] = segments[k++ & (segments.size() - 1)];
    blocked += c.embree->occluded(a, b - a, 1e-4, 1.0 - 1e-4) ? 1 : 0;
    ++rays;
  }
  benchmark::DoNotOptimize(blocked);
  state.counters["rays/s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RawEmbreeOcclusionSingle);

void BM_RawEmbreeOcclusionPacket16(benchmark::State& state) {
  const Cornell& c = cornell();
  Pcg32 rng(7);
  std::vector<Vec3> corners, p, q;
  struct Packet {
    float ox[16], oy[16], oz[16], dx[16], dy[16], dz[16], tn[16], tf[16];
  };
  std::vector<Packet> packets(1 << 12);
  for (Packet& packet : packets) {
    c.mesh.corners(rng.next_below(uint32_t(c.mesh.size())), corners);
    stratified_points(corners, 16, rng, p);
    c.mesh.corners(rng.next_below(uint32_t(c.mesh.size())), corners);
    stratified_points(corners, 16, rng, q);
    for (int k = 0; k < 16; ++k) {
      packet.ox[k] = float(p[size_t(k)].x), packet.oy[k] = float(p[size_t(k)].y);
      packet.oz[k] = float(p[size_t(k)].z);
      packet.dx[k] = float(q[size_t(k)].x - p[size_t(k)].x);
      packet.dy[k] = float(q[size_t(k)].y - p[size_t(k)].y);
      packet.dz[k] = float(q[size_t(k)].z - p[size_t(k)].z);
      packet.tn[k] = 1e-4f;
      packet.tf[k] = 1.0f - 1e-4f;
    }
  }
  size_t k = 0, rays = 0;
  bool out[16];
  for (auto _ : state) {
    const Packet& packet = packets[k++ & (packets.size() - 1)];
    c.embree->occluded16(packet.ox, packet.oy, packet.oz, packet.dx, packet.dy, packet.dz,
                         packet.tn, packet.tf, 16, out);
    benchmark::DoNotOptimize(out);
    rays += 16;
  }
  state.counters["rays/s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RawEmbreeOcclusionPacket16);

void BM_RaycastRows(benchmark::State& state) {
  const Cornell& c = cornell();
  RaycastFormFactors ff(c.scene, c.mesh, {});
  std::vector<double> row(c.mesh.size());
  RowCost cost;
  size_t i = 0, rows = 0;
  for (auto _ : state) {
    ff.row((i * 7919) % c.mesh.size(), row, cost);  // a spread of rows over the box
    ++i;
    ++rows;
  }
  state.counters["rays/s"] = benchmark::Counter(double(cost.rays), benchmark::Counter::kIsRate);
  state.counters["rows/s"] = benchmark::Counter(double(rows), benchmark::Counter::kIsRate);
  state.counters["rays/row"] = double(cost.rays) / double(rows);
  state.counters["kernel/row"] = double(cost.kernel_evaluations) / double(rows);
  state.counters["elements"] = double(c.mesh.size());
}
BENCHMARK(BM_RaycastRows)->Unit(benchmark::kMillisecond);

void BM_DenseMatrixCornell5k(benchmark::State& state) {
  const Cornell& c = cornell();
  RaycastFormFactors ff(c.scene, c.mesh, {});
  for (auto _ : state) {
    BuildReport report;
    FormFactorMatrix m = build_matrix(ff, c.mesh.size(), Precision::kFloat, report);
    benchmark::DoNotOptimize(m.row_f32(0));
    state.counters["rays"] = double(report.cost.rays);
    state.counters["threads"] = report.threads;
  }
  state.counters["elements"] = double(c.mesh.size());
}
BENCHMARK(BM_DenseMatrixCornell5k)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
