// Both cores (issue 13 target 4): each parallel part of radlab timed on 1 thread and on 2, in
// one run, wall clock (a parallel speed-up is a wall-time ratio; CPU time would hide it). The
// machine is shared, so quote the ratios from one run and expect them below 2 when other
// processes hold a core.
//
//   - DenseLu: the reference's LU (solvers/reference/dense_lu.h) against Eigen's PartialPivLU
//   (what the
//     reference used before) at n = 3,000 on I - rho F with F random (rows summing to 0.9).
//   - OnTheFlyRow: one raycast row of the Cornell box at --subdiv 20 (~8,000 elements), the row
//     System::with_row computes on the fly (formfactor/matrix/parallel_row.h).
//   - Shot: one RGB sorted shot's kernel (kernels::shoot with fused selection) on scattered
//     float rows of n receivers (256 MB of rows), split over threads (the split is off by
//     default; turned on here from 2 pieces of kernels::kShotChunk). (bench_solvers.cpp has the
//     kernels against the raw read bandwidth.)
//
// Counters: the wall time per operation and cpu_* (every thread of the process): equal CPU on 1
// and 2 threads means the split adds no work.
//
//   build/bench/bench_threads --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <Eigen/Dense>
#include <chrono>
#include <ctime>
#include <map>
#include <memory>
#include <vector>

#include "core/random.h"
#include "formfactor/matrix/parallel_row.h"
#include "formfactor/registry.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/kernels/kernels.h"
#include "solvers/reference/dense_lu.h"

namespace radlab {
namespace {

// CPU seconds of every thread of the process: the work done, wherever it ran.
double process_cpu() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// ---------------------------------------------------------------------------------------------
// The dense LU.

const Eigen::MatrixXd& lu_matrix() {
  static const Eigen::MatrixXd A = [] {
    const Eigen::Index n = 3000;
    Pcg32 rng(3);
    Eigen::MatrixXd M(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        M(i, j) = (i == j ? 1.0 : 0.0) - 0.9 * 2.0 * rng.next_double() / double(n);
    return M;
  }();
  return A;
}

void BM_DenseLu(benchmark::State& state, bool eigen) {
  const int threads = int(state.range(0));
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, size_t(threads));
  const Eigen::MatrixXd& A = lu_matrix();
  const size_t n = size_t(A.rows());
  std::vector<double> b(n, 1.0), x;
  double seconds = 0.0;
  const double cpu0 = process_cpu();
  for (auto _ : state) {
    const double start = now();
    if (eigen) {
      Eigen::PartialPivLU<Eigen::MatrixXd> lu(A);
      benchmark::DoNotOptimize(lu.matrixLU().data());
    } else {
      BlockedLu lu(n, [&](size_t i, size_t j) { return A(Eigen::Index(i), Eigen::Index(j)); });
      lu.solve(b, x);
      benchmark::DoNotOptimize(x.data());
    }
    seconds += now() - start;
  }
  state.counters["n"] = double(n);
  state.counters["threads"] = threads;
  state.counters["s_per_lu"] = seconds / double(state.iterations());
  state.counters["cpu_s_per_lu"] = (process_cpu() - cpu0) / double(state.iterations());
  state.counters["gflops"] =
      2.0 / 3.0 * double(n) * double(n) * double(n) / (seconds / double(state.iterations())) * 1e-9;
}

// ---------------------------------------------------------------------------------------------
// An on-the-fly row.

struct RowProblem {
  Scene scene;
  Mesh mesh;
  std::unique_ptr<FormFactorMethod> method;
};

const RowProblem& row_problem() {
  static const std::unique_ptr<RowProblem> p = [] {
    auto q = std::make_unique<RowProblem>();
    q->scene = make_builtin_scene("cornell");
    validate_scene(q->scene);
    q->mesh = build_mesh(q->scene, {20, 0.0});
    ParamBag bag;
    q->method = make_form_factor_method("raycast", bag, q->scene, q->mesh);
    return q;
  }();
  return *p;
}

void BM_OnTheFlyRow(benchmark::State& state) {
  const int threads = int(state.range(0));
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, size_t(threads));
  const RowProblem& p = row_problem();
  const size_t n = p.mesh.size();
  std::vector<double> row(n);
  size_t i = 0;
  double seconds = 0.0;
  const double cpu0 = process_cpu();
  for (auto _ : state) {
    RowCost cost;
    const double start = now();
    row_in_parallel(*p.method, (i++ * 7919) % n, row, cost);
    seconds += now() - start;
  }
  state.counters["n"] = double(n);
  state.counters["threads"] = threads;
  state.counters["ms_per_row"] = 1e3 * seconds / double(state.iterations());
  state.counters["cpu_ms_per_row"] = 1e3 * (process_cpu() - cpu0) / double(state.iterations());
}

// ---------------------------------------------------------------------------------------------
// The RGB shot on long rows.

struct ShotProblem {
  size_t n = 0, rows = 0;
  std::vector<float> F;  // rows x n
  std::vector<double> dB[3], rho[3], inverse_area, area;
  kernels::ShotTargets targets;
};

const ShotProblem& shot_problem(size_t n) {
  static std::map<size_t, std::unique_ptr<ShotProblem>> problems;
  auto& slot = problems[n];
  if (slot) return *slot;
  slot = std::make_unique<ShotProblem>();
  ShotProblem& p = *slot;
  p.n = n;
  p.rows = std::max<size_t>(8, (256u << 20) / (n * sizeof(float)));  // 256 MB of rows
  p.F.resize(p.rows * n);
  Pcg32 rng(5);
  for (float& f : p.F) f = float(2e-4 * rng.next_double() / double(n) * 1e4);
  p.inverse_area.resize(n);
  p.area.resize(n);
  for (size_t j = 0; j < n; ++j) {
    p.area[j] = 0.5 + rng.next_double();
    p.inverse_area[j] = 1.0 / p.area[j];
  }
  p.targets.channels = 3;
  for (int c = 0; c < 3; ++c) {
    p.dB[c].assign(n, 1e-3);
    p.rho[c].assign(n, 0.5 + 0.1 * c);
    p.targets.unshot[c] = p.dB[c].data();
    p.targets.reflectance[c] = p.rho[c].data();
  }
  p.targets.inverse_area = p.inverse_area.data();
  p.targets.area = p.area.data();
  return p;
}

void BM_Shot(benchmark::State& state) {
  const size_t n = size_t(state.range(0));
  const int threads = int(state.range(1));
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, size_t(threads));
  const ShotProblem& p = shot_problem(n);
  // The split is off by default (kernels.h); on here from 2 pieces, on 1 thread and on 2.
  const size_t previous = kernels::set_parallel_shot_minimum(2 * kernels::kShotChunk);
  const double k[3] = {1e-9, 1e-9, 1e-9};
  size_t r = 0;
  double seconds = 0.0;
  const double cpu0 = process_cpu();
  for (auto _ : state) {
    const float* F = &p.F[((r++ * 7919) % p.rows) * n];
    const double start = now();
    benchmark::DoNotOptimize(kernels::shoot(F, 0, n, k, 0.0, p.targets, true));
    seconds += now() - start;
  }
  kernels::set_parallel_shot_minimum(previous);
  const double per_row = seconds / double(state.iterations());
  state.counters["n"] = double(n);
  state.counters["threads"] = threads;
  state.counters["us_per_row"] = 1e6 * per_row;
  state.counters["cpu_us_per_row"] = 1e6 * (process_cpu() - cpu0) / double(state.iterations());
}

void register_all() {
  for (int threads : {1, 2}) {
    benchmark::RegisterBenchmark("DenseLu/eigen", BM_DenseLu, true)
        ->Arg(threads)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("DenseLu/blocked", BM_DenseLu, false)
        ->Arg(threads)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  }
  for (int threads : {1, 2})
    benchmark::RegisterBenchmark("OnTheFlyRow/raycast", BM_OnTheFlyRow)
        ->Arg(threads)
        ->Iterations(20)
        ->Unit(benchmark::kMillisecond);
  for (int64_t n : {4096, 16384, 65536, 262144})
    for (int threads : {1, 2})
      benchmark::RegisterBenchmark("Shot/rgb", BM_Shot)
          ->Args({n, threads})
          ->Unit(benchmark::kMicrosecond);
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
