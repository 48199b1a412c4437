// Solver step speed against memory bandwidth, at ~7,000 elements with a dense float matrix.
//
// The matrix is synthetic (building the Cornell box's at this size takes minutes): random
// entries with A_i F_ij = A_j F_ji (to float rounding, so conjugate gradients accepts it) and
// rows summing to ~0.9. The kernels' speed does not depend on the values. The mesh and materials
// are the real ones: the Cornell box (RGB) at --subdiv 19 (7,220 elements) and the cube (grey)
// at --subdiv 34 (6,936 elements).
//
// Baseline: a plain sum over one row that is not in cache (rows visited in a scattered order,
// the matrix is 200 MB), with enough independent sums to be limited by memory, not by adds.
// Every benchmark reports ns per form-factor row and bandwidth_fraction = baseline ns per row /
// its ns per row (1 = as fast as streaming the row; the target is >= 0.5). Run:
//   build/bench/bench_solvers --benchmark_counters_tabular=true
// Quote the ratios from one run; absolute times on this machine are noisy.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>

#include "core/random.h"
#include "formfactor/matrix.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/kernels.h"
#include "solvers/registry.h"
#include "solvers/system.h"

namespace radlab {
namespace {

struct Problem {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix matrix;
  std::unique_ptr<System> system;
};

std::unique_ptr<Problem> make_problem(const std::string& spec, int subdiv) {
  auto p = std::make_unique<Problem>();
  p->scene = make_builtin_scene(spec);
  validate_scene(p->scene);
  p->mesh = build_mesh(p->scene, {subdiv, 0.0});
  const size_t n = p->mesh.size();
  const auto& A = p->mesh.area;
  p->matrix = FormFactorMatrix(n, Precision::kFloat);
  // G_ij = G_ji = u_ij min(A_i, A_j) 0.9 / n, u uniform in [0, 2): F_ij = G_ij / A_i sums to
  // ~0.9 per row and A F is symmetric.
  Pcg32 rng(11);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      const double g = 2.0 * rng.next_double() * std::min(A[i], A[j]) * 0.9 / double(n);
      p->matrix.set(i, j, g / A[i]);
      p->matrix.set(j, i, g / A[j]);
    }
  p->system = std::make_unique<System>(p->scene, p->mesh, p->matrix);
  return p;
}

const Problem& rgb() {
  static const std::unique_ptr<Problem> p = make_problem("cornell", 19);
  return *p;
}
const Problem& grey() {
  static const std::unique_ptr<Problem> p = make_problem("cube", 34);
  return *p;
}

// A plain sum over one row, with 16 independent float sums (what the memory allows).
float row_sum(const float* row, size_t n) {
  float s[16] = {};
  size_t j = 0;
  for (; j + 16 <= n; j += 16)
    for (size_t k = 0; k < 16; ++k) s[k] += row[j + k];
  for (; j < n; ++j) s[0] += row[j];
  float t = 0.0f;
  for (float v : s) t += v;
  return t;
}

// Scattered rows: a stride co-prime with n, so no row is in cache and the hardware prefetcher
// cannot run ahead from one row into the next.
size_t scattered(size_t k, size_t n) {
  return (k * 7919) % n;
}

// The best of 7 timings of 4,000 scattered rows each: the machine's streaming rate, not its
// worst moment.
double baseline_ns_per_row(const Problem& p) {
  const size_t n = p.matrix.size();
  const size_t rows = 4000;
  double best = 1e300;
  size_t k = 0;
  for (int trial = 0; trial < 7; ++trial) {
    float sink = 0.0f;
    const auto start = std::chrono::steady_clock::now();
    for (size_t r = 0; r < rows; ++r) sink += row_sum(p.matrix.row_f32(scattered(k++, n)), n);
    const double ns =
        std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
    benchmark::DoNotOptimize(sink);
    best = std::min(best, ns / double(rows));
  }
  return best;
}

// Measured once per problem, in the same run as the benchmarks.
double baseline(const Problem& p) {
  static const double grey_ns = baseline_ns_per_row(grey());
  static const double rgb_ns = baseline_ns_per_row(rgb());
  return &p == &grey() ? grey_ns : rgb_ns;
}

void report(benchmark::State& state, const Problem& p, uint64_t rows, double seconds) {
  const double ns_per_row = seconds * 1e9 / double(rows);
  state.counters["n"] = double(p.matrix.size());
  state.counters["ns_per_row"] = ns_per_row;
  state.counters["baseline_ns_per_row"] = baseline(p);
  state.counters["bandwidth_fraction"] = baseline(p) / ns_per_row;
}

void BM_StreamRow(benchmark::State& state, const Problem* p) {
  const size_t n = p->matrix.size();
  size_t k = 0;
  float sink = 0.0f;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) sink += row_sum(p->matrix.row_f32(scattered(k++, n)), n);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  benchmark::DoNotOptimize(sink);
  report(state, *p, k, s);
}

// One solver step per iteration, timed as the runner does (rows from System::with_row).
void BM_Step(benchmark::State& state, const Problem* p, const char* name,
             std::vector<std::string> params, bool vector) {
  kernels::use_vector_kernels(vector);
  ParamBag bag = ParamBag::from_assignments(params, name);
  auto solver = make_solver(name, bag);
  solver->init(*p->system);
  p->system->reset_counters();
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) benchmark::DoNotOptimize(solver->step());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report(state, *p, p->system->rows_used(), s);
  kernels::use_vector_kernels(true);
}

// The kernels alone on scattered rows (the access pattern of sorted shooting), to separate the
// cost of the fused selection from the cost of the row order.
void BM_ShotKernel(benchmark::State& state, const Problem* p, bool select) {
  const System& sys = *p->system;
  const size_t n = sys.size();
  Radiosity unshot = sys.emission(), weight(sys.channels(), n);
  kernels::ShotTargets t;
  t.channels = sys.channels();
  for (int c = 0; c < sys.channels(); ++c) {
    for (size_t j = 0; j < n; ++j)
      weight.at(c, j) = sys.reflectance().at(c, j) * sys.inverse_area()[j];
    t.unshot[c] = unshot.channel(c).data();
    t.weight[c] = weight.channel(c).data();
  }
  t.area = sys.area().data();
  const double k[3] = {1e-3, 1e-3, 1e-3};
  size_t row = 0;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state)
    benchmark::DoNotOptimize(
        kernels::shoot(p->matrix.row_f32(scattered(row++, n)), 0, n, k, 0.0, t, select));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report(state, *p, row, s);
}

void BM_GatherKernel(benchmark::State& state, const Problem* p) {
  const System& sys = *p->system;
  const size_t n = sys.size();
  double out[3];
  size_t row = 0;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    kernels::gather(p->matrix.row_f32(scattered(row++, n)), sys.emission(), out);
    benchmark::DoNotOptimize(out[0]);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report(state, *p, row, s);
}

void register_all() {
  for (const Problem* p : {&grey(), &rgb()}) {
    const std::string tag = p == &grey() ? "grey" : "rgb";
    benchmark::RegisterBenchmark(("StreamRow/" + tag).c_str(), BM_StreamRow, p);
    benchmark::RegisterBenchmark((tag + "/kernel/Gather").c_str(), BM_GatherKernel, p);
    benchmark::RegisterBenchmark((tag + "/kernel/Shot(no selection)").c_str(), BM_ShotKernel, p,
                                 false);
    benchmark::RegisterBenchmark((tag + "/kernel/Shot(fused selection)").c_str(), BM_ShotKernel, p,
                                 true);
    struct Case {
      const char* label;
      const char* solver;
      std::vector<std::string> params;
      int iterations;
    };
    const std::vector<Case> cases = {
        {"Gather(gauss-seidel)", "gauss-seidel", {}, 0},
        {"Shot(shooting,no selection)", "shooting", {}, 0},
        {"Shot(sorted-shooting)", "sorted-shooting", {}, 0},
        {"Shot(overshooting,regather)", "overshooting", {}, 0},
        {"CGIteration", "conjugate-gradient", {}, 20},
        {"CGIteration(symmetrise)", "conjugate-gradient", {"symmetrise=true"}, 20},
    };
    for (bool vector : {true, false})
      for (const Case& c : cases) {
        const std::string label = tag + "/" + c.label + (vector ? "" : "/scalar");
        auto* b =
            benchmark::RegisterBenchmark(label.c_str(), BM_Step, p, c.solver, c.params, vector);
        if (c.iterations) b->Iterations(c.iterations);
        b->Unit(benchmark::kMicrosecond);
      }
  }
}

}  // namespace
}  // namespace radlab

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  radlab::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
