// Form-factor speed.
//
// On the Cornell box (~5,000 elements, subdiv 16):
// - raw Embree occlusion rays/s for segments between random points on random elements, singly
//   (rtcOccluded1) and in coherent packets of 16 between two elements (rtcOccluded16), the pattern
//   the raycast method uses;
// - the visibility rays/s the raycast form factors achieve, target >= 0.6 of the raw packet rate,
//   measured two ways, each interleaved with raw packets in one benchmark so that the ratio is
//   immune to the machine's drift: BM_VisibilityVsRawPacketRatio over the visibility stage (what
//   Visibility::fraction does for a row's facing pairs: shaft decisions, sampling, packets,
//   Embree), and BM_RaycastVsRawPacketRatio over whole rows (the quadrature of F^u included,
//   which casts no rays);
// - the dense matrix build on all cores (wall time), with and without the two rows of a pair
//   sharing its visibility.
//
// On builtin:office --subdiv 4 (7,008 elements, Cohen et al. 1988's ~7,000), one thread:
// - one hemicube row at R = 150 (target <= 2 ms on one core; Cohen 1988: 10 s on an HP 825);
// - one raycast row at the default settings.
//
// The close-pair direction sampler against the raw packet rate
// (BM_SolidAngleSamplerVsRawPacketRatio).
//
// Shaft culling's decisions alone, on both scenes: ns per facing pair with the polygon-pair tier
// and with the element-level test alone.
//
// Run: build/bench/bench_formfactors --benchmark_counters_tabular=true
// Quote ratios measured in one run; absolute times on this machine are noisy.
#include <benchmark/benchmark.h>

#include <memory>

#include "bench/bench_clock.h"
#include "bench/bench_scenes.h"
#include "core/random.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/embree_scene.h"
#include "formfactor/visibility/sampling.h"
#include "formfactor/visibility/shaft.h"
#include "formfactor/visibility/visibility.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"

namespace radlab {
namespace {

using bench::cornell;
using bench::office;
using Cornell = bench::SceneMesh;

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

// Packets of 16 segments between stratified points on two random elements.
std::vector<SegmentPacket> make_packets(const Cornell& c, size_t count) {
  Pcg32 rng(7);
  std::vector<Vec3> corners, p, q;
  std::vector<SegmentPacket> packets(count);
  for (SegmentPacket& packet : packets) {
    packet.count = 16;
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
      packet.t_near[k] = 1e-4f;
      packet.t_far[k] = 1.0f - 1e-4f;
    }
  }
  return packets;
}

// The raw half of the ratio benchmarks: casts packets until as many rays as the measured half
// cast have gone, timing only that.
struct RawPackets {
  std::vector<SegmentPacket> packets = make_packets(cornell(), 1 << 12);
  size_t next = 0;
  uint64_t rays = 0;
  double seconds = 0.0;

  void cast(uint64_t count) {
    const uint64_t target = rays + count;
    bool out[16];
    const timespec start = thread_now();
    while (rays < target) {
      cornell().embree->occluded16(packets[next++ & (packets.size() - 1)], out);
      benchmark::DoNotOptimize(out);
      rays += 16;
    }
    seconds += thread_seconds(start);
  }
};

// Sets the counters every ratio benchmark reports: the measured rate (as `rate_name`), the raw
// one, their ratio and rays per row.
void report_ratio(benchmark::State& state, const char* rate_name, uint64_t rays, double seconds,
                  const RawPackets& raw, size_t rows) {
  const double rate = double(rays) / seconds;
  const double raw_rate = double(raw.rays) / raw.seconds;
  state.counters[rate_name] = rate;
  state.counters["raw16 rays/s"] = raw_rate;
  state.counters["ratio"] = rate / raw_rate;
  state.counters["rays/row"] = double(rays) / double(rows);
}

void BM_RawEmbreeOcclusionPacket16(benchmark::State& state) {
  const Cornell& c = cornell();
  const std::vector<SegmentPacket> packets = make_packets(c, 1 << 12);
  size_t k = 0, rays = 0;
  bool out[16];
  for (auto _ : state) {
    const SegmentPacket& packet = packets[k++ & (packets.size() - 1)];
    c.embree->occluded16(packet, out);
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

// The >= 0.6 target over whole rows (the visibility stage alone: BM_VisibilityVsRawPacketRatio
// below; docs/formfactors.md, "Speed", says why that is the reading the target is held to): each
// iteration computes one raycast row (timed),
// then casts as many raw rtcOccluded16 rays as that row did (timed); both on the thread's CPU
// clock, so both halves see the same machine and other processes' load does not count. The ratio
// of the two rates is reported as "ratio". Argument: shaft culling on (1, the default) or off (0).
// With shafts on, a row casts fewer rays for the same quadrature work, so its rays/s (and the
// ratio) fall although the row gets faster: "ratio" with shafts=0 is the method's ray throughput,
// with shafts=1 what the default settings achieve.
void BM_RaycastVsRawPacketRatio(benchmark::State& state) {
  const Cornell& c = cornell();
  RaycastOptions options;
  options.shafts = state.range(0) != 0;
  RaycastFormFactors ff(c.scene, c.mesh, options);
  RawPackets raw;
  std::vector<double> row(c.mesh.size());
  RowCost cost;
  double row_seconds = 0.0;
  size_t i = 0;
  for (auto _ : state) {
    const uint64_t before = cost.rays;
    const timespec start = thread_now();
    ff.row((i++ * 7919) % c.mesh.size(), row, cost);
    row_seconds += thread_seconds(start);
    raw.cast(cost.rays - before);
  }
  report_ratio(state, "raycast rays/s", cost.rays, row_seconds, raw, i);
  state.counters["row ms"] = 1e3 * row_seconds / double(i);
}
BENCHMARK(BM_RaycastVsRawPacketRatio)
    ->ArgName("shafts")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(3.0);

// The visibility stage alone, against the same raw packet rate, interleaved as above: each
// iteration asks Visibility::fraction for every facing pair of one row (what
// RaycastFormFactors::row asks: shaft decision, sampling, packets, Embree) and times that; then
// casts as many raw rtcOccluded16 rays. "ratio" is the rate at which the visibility stage delivers
// its rays over the rate of bare Embree packets: the overhead radlab adds around Embree. (The
// quadrature of F^u, the rest of a row, casts no rays; BM_RaycastVsRawPacketRatio includes it.)
void BM_VisibilityVsRawPacketRatio(benchmark::State& state) {
  const Cornell& c = cornell();
  const bool shafts = state.range(0) != 0;
  const RaycastOptions defaults;
  const Visibility visibility(c.scene, c.mesh, defaults.rays, defaults.seed, shafts);
  const double eps = plane_epsilon(c.mesh);
  RawPackets raw;
  std::vector<uint32_t> facing;
  RowCost cost;
  double sum = 0.0, stage_seconds = 0.0;
  size_t i = 0, pairs = 0;
  for (auto _ : state) {
    const size_t row = (i++ * 7919) % c.mesh.size();
    facing.clear();
    for (size_t j = 0; j < c.mesh.size(); ++j)
      if (j != row && pair_faces(c.mesh, row, j, eps)) facing.push_back(uint32_t(j));
    pairs += facing.size();
    const uint64_t before = cost.rays;
    const timespec start = thread_now();
    for (uint32_t j : facing) sum += visibility.fraction(row, j, cost);
    stage_seconds += thread_seconds(start);
    raw.cast(cost.rays - before);
  }
  benchmark::DoNotOptimize(sum);
  report_ratio(state, "visibility rays/s", cost.rays, stage_seconds, raw, i);
  state.counters["ns/pair"] = 1e9 * stage_seconds / double(pairs);
}
BENCHMARK(BM_VisibilityVsRawPacketRatio)
    ->ArgName("shafts")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(3.0);

// The direction sampler of close pairs (SolidAngleSampler: one per ray, made at the ray's source
// point, then one point drawn), against the same raw packet rate, interleaved as above: each
// iteration draws 4,096 points as trace_close does (a jittered source point on a 0.4 m square
// 0.1 m in front of a unit quad, a stratified (u, v) for the direction), then casts as many raw
// rtcOccluded16 rays. "ratio" is the sampler's points/s over the raw rays/s: how many rays' worth
// of Embree time one sample costs is 1 / ratio. (hospital.mgf's build spent ~25% of its time here
// before 2026-11-27: docs/formfactors.md, "hospital.mgf's build, profiled and cut".) Argument
// batch: 0 one SolidAngleSampler per point, 1 sample_solid_angles over lanes of 16 (what
// trace_close calls since stop 27; the same bits).
void BM_SolidAngleSamplerVsRawPacketRatio(benchmark::State& state) {
  const bool batch = state.range(0) != 0;
  const std::vector<Vec3> quad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.02}, {0, 1, 0}};
  const Vec3 normal = glm::normalize(glm::cross(quad[1] - quad[0], quad[3] - quad[0]));
  constexpr int kSamples = 4096;
  RawPackets raw;
  Pcg32 rng(11);
  Vec3 sum(0.0);
  double seconds = 0.0;
  uint64_t samples = 0;
  for (auto _ : state) {
    const timespec start = thread_now();
    SolidAngleLanes lanes;
    for (int k = 0; k < kSamples; ++k) {
      const Vec3 x(0.3 + 0.4 * rng.next_double(), 0.3 + 0.4 * rng.next_double(), 0.1);
      const double u = ((k & 63) + rng.next_double()) / 64.0,
                   v = ((k >> 6) + rng.next_double()) / 64.0;
      if (!batch) {
        const SolidAngleSampler toward(x, quad, normal);
        sum += toward.solid_angle() * toward.point(u, v);
        continue;
      }
      const int lane = k % SolidAngleLanes::kLanes;
      lanes.x[0][lane] = x.x, lanes.x[1][lane] = x.y, lanes.x[2][lane] = x.z;
      lanes.u[lane] = u, lanes.v[lane] = v;
      if (lane + 1 < SolidAngleLanes::kLanes) continue;
      sample_solid_angles(quad, normal, SolidAngleLanes::kLanes, lanes);
      for (int l = 0; l < SolidAngleLanes::kLanes; ++l)
        sum += lanes.omega[l] * Vec3(lanes.y[0][l], lanes.y[1][l], lanes.y[2][l]);
    }
    seconds += thread_seconds(start);
    samples += kSamples;
    raw.cast(kSamples);
  }
  benchmark::DoNotOptimize(sum);
  const double rate = double(samples) / seconds, raw_rate = double(raw.rays) / raw.seconds;
  state.counters["samples/s"] = rate;
  state.counters["raw16 rays/s"] = raw_rate;
  state.counters["ratio"] = rate / raw_rate;
  state.counters["ns/sample"] = 1e9 * seconds / double(samples);
}
BENCHMARK(BM_SolidAngleSamplerVsRawPacketRatio)
    ->ArgName("batch")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

// Shaft culling's decisions alone (shaft.h), on the facing pairs of 64 rows spread over the mesh:
// argument 1 the default two tiers (polygon-pair candidates, then the element-level test on them),
// 0 the element-level test alone over the whole polygon hierarchy. The per-thread cache of
// polygon pairs is warm after the first rows, as it is while a thread computes many rows.
// Reports pairs/s, ns/pair (CPU time) and the share of pairs proven clear.
void shaft_decisions(benchmark::State& state, const Scene& scene, const Mesh& mesh) {
  const double eps = plane_epsilon(mesh);
  const ShaftCuller shafts(scene, mesh, eps);
  const bool tiers = state.range(0) != 0;
  std::vector<std::pair<uint32_t, std::vector<uint32_t>>> rows(64);
  for (size_t r = 0; r < rows.size(); ++r) {
    const size_t i = (r * 7919) % mesh.size();
    rows[r].first = uint32_t(i);
    for (size_t j = 0; j < mesh.size(); ++j)
      if (j != i && pair_faces(mesh, i, j, eps)) rows[r].second.push_back(uint32_t(j));
  }
  size_t pairs = 0, clear = 0, r = 0;
  const timespec cpu_start = thread_now();
  for (auto _ : state) {
    const auto& [i, js] = rows[r++ % rows.size()];
    for (uint32_t j : js)
      clear += (tiers ? shafts.first_blocker(i, j) : shafts.element_level_blocker(i, j)) < 0;
    pairs += js.size();
  }
  state.counters["pairs/s"] = benchmark::Counter(double(pairs), benchmark::Counter::kIsRate);
  state.counters["ns/pair"] = 1e9 * thread_seconds(cpu_start) / double(pairs);
  state.counters["clear %"] = 100.0 * double(clear) / double(pairs);
  state.counters["polygons"] = double(shafts.polygon_count());
}

void BM_ShaftDecisionsCornell5k(benchmark::State& state) {
  const Cornell& c = cornell();
  shaft_decisions(state, c.scene, c.mesh);
}
BENCHMARK(BM_ShaftDecisionsCornell5k)->ArgName("tiers")->Arg(1)->Arg(0);

void BM_ShaftDecisionsOffice7k(benchmark::State& state) {
  const auto& o = office();
  shaft_decisions(state, o.scene, o.mesh);
}
BENCHMARK(BM_ShaftDecisionsOffice7k)->ArgName("tiers")->Arg(1)->Arg(0);

// Rows of one method on the office (one thread), spread over the mesh; reports the CPU time of
// one row (ms/row; the wall time is longer when other processes share the core).
void office_rows(benchmark::State& state, const FormFactorMethod& method) {
  const auto& o = office();
  std::vector<double> row(o.mesh.size());
  RowCost cost;
  size_t i = 0, rows = 0;
  const timespec cpu_start = thread_now();
  for (auto _ : state) {
    method.row((i * 7919) % o.mesh.size(), row, cost);
    benchmark::DoNotOptimize(row.data());
    ++i;
    ++rows;
  }
  state.counters["rows/s"] = benchmark::Counter(double(rows), benchmark::Counter::kIsRate);
  state.counters["ms/row"] = 1e3 * thread_seconds(cpu_start) / double(rows);
  state.counters["rays/row"] = double(cost.rays) / double(rows);
  state.counters["kernel/row"] = double(cost.kernel_evaluations) / double(rows);
  state.counters["elements"] = double(o.mesh.size());
}

void BM_HemicubeRowOffice7k(benchmark::State& state) {
  const auto& o = office();
  HemicubeOptions options;
  options.resolution = int(state.range(0));
  HemicubeFormFactors ff(o.scene, o.mesh, options);
  office_rows(state, ff);
}
BENCHMARK(BM_HemicubeRowOffice7k)->Arg(150)->Unit(benchmark::kMillisecond);

void BM_RaycastRowOffice7k(benchmark::State& state) {
  const auto& o = office();
  RaycastFormFactors ff(o.scene, o.mesh, {});
  office_rows(state, ff);
}
BENCHMARK(BM_RaycastRowOffice7k)->Unit(benchmark::kMillisecond);

// The dense matrix on all cores: wall time (UseRealTime), also as the "build s" counter.
// A method's rows without its begin/end_all_rows: the dense build then computes every row on
// its own, as before pairs shared their visibility (to measure what the sharing saves).
class RowsOnly final : public FormFactorMethod {
 public:
  explicit RowsOnly(const FormFactorMethod& method) : method_(method) {}
  std::string name() const override { return method_.name(); }
  std::string parameters() const override { return method_.parameters(); }
  void row(size_t i, std::span<double> out, RowCost& cost) const override {
    method_.row(i, out, cost);
  }
  double stated_row_sum_error(std::string* basis) const override {
    return method_.stated_row_sum_error(basis);
  }

 private:
  const FormFactorMethod& method_;
};

// The dense build on all cores (wall time). Argument `shared`: 1 the default (each pair's
// visibility traced once, for both rows), 0 every row on its own.
void BM_DenseMatrixCornell5k(benchmark::State& state) {
  const Cornell& c = cornell();
  RaycastFormFactors ff(c.scene, c.mesh, {});
  const RowsOnly rows_only(ff);
  const FormFactorMethod& method =
      state.range(0) != 0 ? static_cast<const FormFactorMethod&>(ff) : rows_only;
  for (auto _ : state) {
    BuildReport report;
    FormFactorMatrix m = build_matrix(method, c.mesh.size(), Precision::kFloat, report);
    benchmark::DoNotOptimize(m.row_f32(0));
    state.counters["build s"] = report.seconds;
    state.counters["rays"] = double(report.cost.rays);
    state.counters["threads"] = report.threads;
  }
  state.counters["elements"] = double(c.mesh.size());
}
BENCHMARK(BM_DenseMatrixCornell5k)
    ->ArgName("shared")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace
}  // namespace radlab

BENCHMARK_MAIN();
