// Solver step speed against memory bandwidth, at ~7,000 elements with a dense float matrix.
//
// The matrix is synthetic (building the Cornell box's at this size takes minutes): random
// entries with A_i F_ij = A_j F_ji (to float rounding, so conjugate gradients accepts it) and
// rows summing to ~0.9. The kernels' speed does not depend on the values. The mesh and materials
// are the real ones: the Cornell box (RGB) at --subdiv 19 (7,220 elements) and the cube (grey)
// at --subdiv 34 (6,936 elements).
//
// Baselines: a plain sum over one row (16 independent float sums, so memory and not the adds
// limits it), in the two orders solvers read rows:
//   - in order: rows i, i+1, i+2, ... (Jacobi, Gauss-Seidel, cyclic shooting, CG's mat-vec). The
//     hardware prefetcher runs on from one row into the next;
//   - scattered: rows (7919 k) mod n (sorted shooting, overshooting, interleaving pick rows by
//     priority or coverage). Each row starts cold: no prefetcher has seen it coming.
// Every benchmark reports ns per form-factor row and bandwidth_fraction = baseline ns per row /
// its ns per row, against the baseline of the order it really reads rows in (`order`: 0 = in
// order, 1 = scattered). 1 = as fast as streaming the row; the target is >= 0.5. The matrix
// (200 MB) is larger than any cache level that one core gets to itself. raw_fraction is the same
// ratio against the raw read of the same rows in the same order (raw_read: 256-bit loads into 8
// sums where the CPU has AVX2), what one core can stream (issue 13 target 5: >= 0.5). Run:
//   build/bench/bench_solvers --benchmark_counters_tabular=true
// Quote the ratios from one run; absolute times on this machine are noisy. Kernels: no suffix =
// the default (AVX2 where the CPU has it; the label names the set that ran), /avx512 = the
// AVX-512 versions, /scalar = the scalar ones.
// kernel/GatherPair: two rows a pass (kernels::gather_pair, as Jacobi and conjugate gradients
// read dense rows), per row; labelled with the set the pair ran on (RGB pairs run on AVX-512
// wherever it is permitted, kernels.cpp, pair_set; so do Jacobi's, CG's and interleaving's, whose
// labels then add "pairs avx512").
// rgb/gapped/*: one RGB gather and one RGB sorted shot on a matrix with half its entries zero,
// dense, sparse through a scratch row, and sparse through kernels::RunRow (the sparse layout's
// path).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstring>
#include <ctime>
#include <memory>

#include "core/random.h"
#include "formfactor/matrix/matrix.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/kernels/kernels.h"
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

// The raw read: the same bytes as fast as this core can stream them, with 256-bit loads into 8
// independent sums where the CPU has AVX2 (the generic x86-64 row_sum above is limited by its
// 128-bit adds as much as by memory: issue 13 measured it at 0.61 of this). Adds only, so nothing
// but the loads limits it.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx2"))) float raw_read_avx2(const float* row, size_t n) {
  typedef float v8f __attribute__((vector_size(32)));
  v8f s[8] = {};
  size_t j = 0;
  for (; j + 64 <= n; j += 64)
    for (int q = 0; q < 8; ++q) {
      v8f v;
      std::memcpy(&v, row + j + 8 * q, sizeof v);
      s[q] += v;
    }
  float t = 0.0f;
  for (int q = 0; q < 8; ++q)
    for (int l = 0; l < 8; ++l) t += s[q][l];
  for (; j < n; ++j) t += row[j];
  return t;
}
bool have_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}
#else
float raw_read_avx2(const float* row, size_t n) {
  return row_sum(row, n);
}
bool have_avx2() {
  return false;
}
#endif

float raw_read(const float* row, size_t n) {
  static const bool avx2 = have_avx2();
  return avx2 ? raw_read_avx2(row, n) : row_sum(row, n);
}

enum class Order { kInOrder = 0, kScattered = 1 };

// The time this thread has run, in seconds. Every time below is CPU time, not wall time: on a
// shared machine another process's time slices would otherwise land on whichever benchmark was
// running (they doubled some wall times here). Caches and memory stay shared, so quote ratios
// from one run.
double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Scattered rows: a stride co-prime with n, so no row is in cache and the hardware prefetcher
// cannot run ahead from one row into the next.
size_t scattered(size_t k, size_t n) {
  return (k * 7919) % n;
}
size_t row_index(Order order, size_t k, size_t n) {
  return order == Order::kInOrder ? k % n : scattered(k, n);
}

// The best of 7 timings of 4,000 rows each in the given order: the machine's streaming rate,
// not its worst moment. The row counter carries on across trials, so no trial re-reads the rows
// of the one before (4,000 rows are 110 MB).
double baseline_ns_per_row(const Problem& p, Order order, float (*read)(const float*, size_t)) {
  const size_t n = p.matrix.size();
  const size_t rows = 4000;
  double best = 1e300;
  size_t k = 0;
  for (int trial = 0; trial < 7; ++trial) {
    float sink = 0.0f;
    const double start = cpu_seconds();
    for (size_t r = 0; r < rows; ++r) sink += read(p.matrix.row_f32(row_index(order, k++, n)), n);
    const double ns = (cpu_seconds() - start) * 1e9;
    benchmark::DoNotOptimize(sink);
    best = std::min(best, ns / double(rows));
  }
  return best;
}

// Measured once per problem, order and kind (0: row_sum, 1: raw read), in the same run as the
// benchmarks.
double baseline(const Problem& p, Order order, int kind = 0) {
  static double cache[2][2][2] = {};  // [grey?][order][kind]
  double& b = cache[&p == &grey() ? 1 : 0][int(order)][kind];
  if (b == 0.0) b = baseline_ns_per_row(p, order, kind == 0 ? row_sum : raw_read);
  return b;
}

void report(benchmark::State& state, const Problem& p, Order order, uint64_t rows, double seconds) {
  const double ns_per_row = seconds * 1e9 / double(rows);
  const double base = baseline(p, order);
  state.counters["n"] = double(p.matrix.size());
  state.counters["order"] = double(order);
  state.counters["ns_per_row"] = ns_per_row;
  state.counters["baseline_ns_per_row"] = base;
  state.counters["bandwidth_fraction"] = base / ns_per_row;
  // Against the raw read of the same rows in the same order (issue 13 target 5: >= 0.5).
  state.counters["raw_ns_per_row"] = baseline(p, order, 1);
  state.counters["raw_fraction"] = baseline(p, order, 1) / ns_per_row;
}

void BM_StreamRow(benchmark::State& state, const Problem* p, Order order) {
  const size_t n = p->matrix.size();
  size_t k = 0;
  float sink = 0.0f;
  const double start = cpu_seconds();
  for (auto _ : state) sink += row_sum(p->matrix.row_f32(row_index(order, k++, n)), n);
  const double s = cpu_seconds() - start;
  benchmark::DoNotOptimize(sink);
  report(state, *p, order, k, s);
}

// The kernels a benchmark runs: the default (AVX2 where the CPU has it), AVX-512 or the scalar
// ones. The label names the set that ran; a set the CPU lacks is reported as an error.
enum class Kernels { kDefault, kAvx512, kScalar };

void use(benchmark::State& state, Kernels k) {
  if (k == Kernels::kDefault)
    kernels::use_vector_kernels(true);
  else if (!kernels::use_kernels(k == Kernels::kAvx512 ? kernels::KernelSet::kAvx512
                                                       : kernels::KernelSet::kScalar))
    state.SkipWithError("this CPU lacks these kernels");
  state.SetLabel(kernels::kernel_set_name(kernels::kernels_in_use()));
}

std::string suffix(Kernels k) {
  return k == Kernels::kDefault ? "" : k == Kernels::kAvx512 ? "/avx512" : "/scalar";
}

// One solver step per iteration, timed as the runner does (rows from System::with_row).
void BM_Step(benchmark::State& state, const Problem* p, const char* name,
             std::vector<std::string> params, Order order, Kernels k) {
  use(state, k);
  // Jacobi, CG and interleaving gather dense rows two a pass (kernels::gather_pair), RGB pairs on
  // AVX-512 even where the rest runs AVX2: the label says so.
  const kernels::KernelSet pairs = kernels::gather_pair_kernels(p->system->channels());
  const std::string solver_name(name);
  if ((solver_name == "jacobi" || solver_name == "conjugate-gradient" ||
       solver_name == "interleaved") &&
      pairs != kernels::kernels_in_use())
    state.SetLabel(std::string(kernels::kernel_set_name(kernels::kernels_in_use())) + ", pairs " +
                   kernels::kernel_set_name(pairs));
  ParamBag bag = ParamBag::from_assignments(params, name);
  auto solver = make_solver(name, bag);
  solver->init(*p->system);
  p->system->reset_counters();
  const double start = cpu_seconds();
  for (auto _ : state) benchmark::DoNotOptimize(solver->step());
  const double s = cpu_seconds() - start;
  report(state, *p, order, p->system->rows_used(), s);
  kernels::use_vector_kernels(true);
}

// One shot (ShootingCore::shoot: the kernel over the receivers and the shooter's own books) on
// scattered rows, the access pattern of sorted shooting, without the solvers' selection logic:
// to separate the cost of the fused selection from the rest of a step. With offsets, the
// selection is overshooting's A_j sum_c |dB_cj + o_cj| (o: one more array read per channel).
void BM_ShotKernel(benchmark::State& state, const Problem* p, bool select, bool offsets,
                   Kernels k) {
  use(state, k);
  const System& sys = *p->system;
  const size_t n = sys.size();
  ShootingCore core;
  core.init(sys);
  Radiosity o(sys.channels(), n);
  for (double& v : o.raw()) v = 1e-4;
  if (offsets) core.set_priority_offset(&o);
  const double s[3] = {1e-3, 1e-3, 1e-3};
  size_t row = 0;
  const double start = cpu_seconds();
  for (auto _ : state) {
    const size_t i = scattered(row++, n);
    benchmark::DoNotOptimize(core.shoot(p->matrix.row_f32(i), i, s, select));
  }
  const double t = cpu_seconds() - start;
  report(state, *p, Order::kScattered, row, t);
  kernels::use_vector_kernels(true);
}

// The gather kernel on rows in order (as Gauss-Seidel reads them).
void BM_GatherKernel(benchmark::State& state, const Problem* p, Kernels k) {
  use(state, k);
  const System& sys = *p->system;
  const size_t n = sys.size();
  double out[3];
  size_t row = 0;
  const double start = cpu_seconds();
  for (auto _ : state) {
    kernels::gather(p->matrix.row_f32(row++ % n), sys.emission(), out);
    benchmark::DoNotOptimize(out[0]);
  }
  const double s = cpu_seconds() - start;
  report(state, *p, Order::kInOrder, row, s);
  kernels::use_vector_kernels(true);
}

// The paired gather kernel (Jacobi's and conjugate gradients' dense rows): rows i and i+1 in one
// pass, rows in order; reported per row.
void BM_GatherPairKernel(benchmark::State& state, const Problem* p, Kernels k) {
  use(state, k);
  const System& sys = *p->system;
  const size_t n = sys.size();
  state.SetLabel(kernels::kernel_set_name(kernels::gather_pair_kernels(sys.channels())));
  double out[2][3];
  size_t row = 0;
  const double start = cpu_seconds();
  for (auto _ : state) {
    const size_t i = row % (n - 1);
    kernels::gather_pair(p->matrix.row_f32(i), p->matrix.row_f32(i + 1), sys.emission(), out[0],
                         out[1]);
    benchmark::DoNotOptimize(out[0][0]);
    benchmark::DoNotOptimize(out[1][0]);
    row += 2;
  }
  const double s = cpu_seconds() - start;
  report(state, *p, Order::kInOrder, row, s);
  kernels::use_vector_kernels(true);
}

// The RGB problem's matrix with half its entries zero in blocks of 64 columns (a culled or
// occluded polygon: every other block of each row, alternating from row to row), in the dense
// and in the sparse layout, to time one sorted shot on each form of the same rows.
struct Gapped {
  FormFactorMatrix dense, sparse;
};
const Gapped& gapped() {
  static const std::unique_ptr<Gapped> g = [] {
    const FormFactorMatrix& m = rgb().matrix;
    const size_t n = m.size();
    auto out = std::make_unique<Gapped>();
    out->dense = FormFactorMatrix(n, Precision::kFloat);
    out->sparse = FormFactorMatrix(n, Precision::kFloat, Layout::kSparse);
    std::vector<double> row(n);
    for (size_t i = 0; i < n; ++i) {
      for (size_t j = 0; j < n; ++j) row[j] = (j / 64 + i) % 2 ? double(m.row_f32(i)[j]) : 0.0;
      out->dense.set_row(i, row);
      out->sparse.set_row(i, row);
    }
    return out;
  }();
  return *g;
}

// One RGB sorted shot (ShootingCore::shoot, fused selection) on scattered rows of the gapped
// matrix: form 0 = its dense rows, 1 = its sparse rows expanded into the scratch row
// (FormFactorMatrix::visit_row, the path before kernels::RunRow), 2 = its sparse rows' stored
// runs (System::with_compact_row's path). raw_fraction is against the dense rows' raw read.
void BM_GappedShot(benchmark::State& state, int form) {
  const Problem& p = rgb();
  const Gapped& g = gapped();
  const size_t n = p.system->size();
  ShootingCore core;
  core.init(*p.system);
  const double s[3] = {1e-3, 1e-3, 1e-3};
  size_t row = 0;
  const double start = cpu_seconds();
  for (auto _ : state) {
    const size_t i = scattered(row++, n);
    const FormFactorMatrix::SparseRow& r = g.sparse.sparse_row(i);
    if (form == 0)
      benchmark::DoNotOptimize(core.shoot(g.dense.row_f32(i), i, s, true));
    else if (form == 1)
      g.sparse.visit_row(
          i, [&](const auto* F) { benchmark::DoNotOptimize(core.shoot(F, i, s, true)); });
    else
      benchmark::DoNotOptimize(core.shoot(
          kernels::RunRow<float>{r.run.data(), r.run.size() / 2, r.f32.data(), r.f32.size()}, i, s,
          true));
  }
  const double t = cpu_seconds() - start;
  report(state, p, Order::kScattered, row, t);
}

// The RGB gather (Jacobi's, rows in order) on the gapped matrix's three row forms, as above.
void BM_GappedGather(benchmark::State& state, int form) {
  const Problem& p = rgb();
  const Gapped& g = gapped();
  const Radiosity& x = p.system->emission();
  const size_t n = p.system->size();
  double out[3];
  size_t row = 0;
  const double start = cpu_seconds();
  for (auto _ : state) {
    const size_t i = row++ % n;
    const FormFactorMatrix::SparseRow& r = g.sparse.sparse_row(i);
    if (form == 0)
      kernels::gather(g.dense.row_f32(i), x, out);
    else if (form == 1)
      g.sparse.visit_row(i, [&](const auto* F) { kernels::gather(F, x, out); });
    else
      kernels::gather(
          kernels::RunRow<float>{r.run.data(), r.run.size() / 2, r.f32.data(), r.f32.size()}, x,
          out);
    benchmark::DoNotOptimize(out[0]);
  }
  const double t = cpu_seconds() - start;
  report(state, p, Order::kInOrder, row, t);
}

void register_all() {
  benchmark::RegisterBenchmark("rgb/gapped/Gather(dense)", BM_GappedGather, 0);
  benchmark::RegisterBenchmark("rgb/gapped/Gather(sparse, scratch row)", BM_GappedGather, 1);
  benchmark::RegisterBenchmark("rgb/gapped/Gather(sparse, runs)", BM_GappedGather, 2);
  benchmark::RegisterBenchmark("rgb/gapped/Shot(dense)", BM_GappedShot, 0);
  benchmark::RegisterBenchmark("rgb/gapped/Shot(sparse, scratch row)", BM_GappedShot, 1);
  benchmark::RegisterBenchmark("rgb/gapped/Shot(sparse, runs)", BM_GappedShot, 2);
  for (const Problem* p : {&grey(), &rgb()}) {
    const std::string tag = p == &grey() ? "grey" : "rgb";
    benchmark::RegisterBenchmark(("StreamRow/" + tag + "/in-order").c_str(), BM_StreamRow, p,
                                 Order::kInOrder);
    benchmark::RegisterBenchmark(("StreamRow/" + tag + "/scattered").c_str(), BM_StreamRow, p,
                                 Order::kScattered);
    // The default kernels (AVX2) and AVX-512 side by side.
    for (Kernels k : {Kernels::kDefault, Kernels::kAvx512}) {
      const std::string end = suffix(k);
      benchmark::RegisterBenchmark((tag + "/kernel/Gather" + end).c_str(), BM_GatherKernel, p, k);
      benchmark::RegisterBenchmark((tag + "/kernel/GatherPair" + end).c_str(), BM_GatherPairKernel,
                                   p, k);
      benchmark::RegisterBenchmark((tag + "/kernel/Shot(no selection)" + end).c_str(),
                                   BM_ShotKernel, p, false, false, k);
      benchmark::RegisterBenchmark((tag + "/kernel/Shot(fused selection)" + end).c_str(),
                                   BM_ShotKernel, p, true, false, k);
      benchmark::RegisterBenchmark(
          (tag + "/kernel/Shot(fused selection, overshoot offsets)" + end).c_str(), BM_ShotKernel,
          p, true, true, k);
    }
    struct Case {
      const char* label;
      const char* solver;
      std::vector<std::string> params;
      Order order;
      int iterations;
    };
    const Order in_order = Order::kInOrder, scattered = Order::kScattered;
    const std::vector<Case> cases = {
        {"Gather(jacobi)", "jacobi", {}, in_order, 0},
        {"Gather(gauss-seidel)", "gauss-seidel", {}, in_order, 0},
        {"Shot(shooting,no selection)", "shooting", {}, in_order, 0},
        {"Shot(sorted-shooting)", "sorted-shooting", {}, scattered, 0},
        {"Shot(overshooting,regather)", "overshooting", {}, scattered, 0},
        // Sorted shots that also record the coverage dff (Wu & Wang's Figs. 2 and 4).
        {"Shot(interleaved,gathers=0)", "interleaved", {"gathers=0"}, scattered, 0},
        // The default sessions: 400 shots, then 400 gathers at the least-covered elements
        // (scattered rows too), with the session changes and the pre-receipt corrections.
        // 8,000 steps: 10 sessions of each kind.
        {"Step(interleaved)", "interleaved", {}, scattered, 8000},
        {"CGIteration", "conjugate-gradient", {}, in_order, 20},
        {"CGIteration(symmetrise)", "conjugate-gradient", {"symmetrise=true"}, in_order, 20},
    };
    const auto add = [&](const Case& c, Kernels k) {
      const std::string label = tag + "/" + c.label + suffix(k);
      auto* b =
          benchmark::RegisterBenchmark(label.c_str(), BM_Step, p, c.solver, c.params, c.order, k);
      if (c.iterations) b->Iterations(c.iterations);
      b->Unit(benchmark::kMicrosecond);
    };
    // The default kernels (AVX2) and AVX-512 back to back, case by case, so that the two are
    // measured in the same state of a shared machine; the scalar ones last.
    for (const Case& c : cases) {
      add(c, Kernels::kDefault);
      add(c, Kernels::kAvx512);
    }
    for (const Case& c : cases) add(c, Kernels::kScalar);
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
