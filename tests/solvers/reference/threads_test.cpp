// Issue 13 target 4, "both cores everywhere, the same bits whatever the thread count": on-the-fly
// rows split over receivers (formfactor/matrix/parallel_row.h), the reference's blocked
// parallel LU (solvers/reference/dense_lu.h) and the --threads option. Each parallel result is
// compared bit for bit on 1, 2 and 4 threads (an explicit task arena, so 4 threads run even on a
// 2-core machine).
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "core/random.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/parallel_row.h"
#include "formfactor/registry.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/kernels/kernels.h"
#include "solvers/reference/dense_lu.h"
#include "solvers/registry.h"
#include "solvers/system.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// Runs fn on exactly `threads` threads (a global_control lifts TBB's cap to the core count).
template <class Fn>
void on_threads(int threads, Fn&& fn) {
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, size_t(threads));
  tbb::task_arena arena(threads);
  arena.execute(fn);
}

bool same_bits(std::span<const double> a, std::span<const double> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

struct Problem {
  Scene scene;
  Mesh mesh;
  std::unique_ptr<FormFactorMethod> method;
};

std::unique_ptr<Problem> make_problem(const std::string& spec, int subdiv, const std::string& ff,
                                      std::vector<std::string> set = {}) {
  auto p = std::make_unique<Problem>();
  p->scene = make_builtin_scene(spec);
  validate_scene(p->scene);
  p->mesh = build_mesh(p->scene, {subdiv, 0.0});
  ParamBag bag = ParamBag::from_assignments(set, ff);
  p->method = make_form_factor_method(ff, bag, p->scene, p->mesh);
  return p;
}

// The Cornell box's two blocks occlude: raycast traces rays for many pairs (seeded per pair).
TEST(ParallelRow, RaycastRowIsRowBitForBitOnOneTwoFourThreads) {
  auto p = make_problem("cornell", 4, "raycast");
  const size_t n = p->mesh.size();
  ASSERT_GT(n, 4 * kRowBlock);  // several blocks per row
  for (size_t i : {size_t(0), n / 3, n - 1}) {
    std::vector<double> serial(n);
    RowCost serial_cost;
    p->method->row(i, serial, serial_cost);
    ASSERT_GT(serial_cost.rays, 0u) << "row " << i << " traces no rays: not a test of visibility";
    for (int threads : {1, 2, 4}) {
      std::vector<double> parallel(n, -1.0);
      RowCost cost;
      on_threads(threads, [&] { row_in_parallel(*p->method, i, parallel, cost); });
      EXPECT_TRUE(same_bits(serial, parallel)) << "row " << i << ", " << threads << " threads";
      EXPECT_EQ(cost.rays, serial_cost.rays);
      EXPECT_EQ(cost.kernel_evaluations, serial_cost.kernel_evaluations);
      EXPECT_EQ(cost.pairs_culled, serial_cost.pairs_culled);
      EXPECT_EQ(cost.pairs_traced, serial_cost.pairs_traced);
      EXPECT_EQ(cost.pairs_unoccluded, serial_cost.pairs_unoccluded);
    }
  }
}

TEST(ParallelRow, ExactAndHemicubeRowsAreTheirRows) {
  // exact splits its rows; the hemicube cannot (one z-buffer) and falls back to row().
  for (const char* ff : {"exact", "hemicube"}) {
    auto p = make_problem("cube", 6, ff);
    const size_t n = p->mesh.size();
    std::vector<double> serial(n), parallel(n, -1.0);
    RowCost a, b;
    p->method->row(7, serial, a);
    on_threads(2, [&] { row_in_parallel(*p->method, 7, parallel, b); });
    EXPECT_TRUE(same_bits(serial, parallel)) << ff;
    EXPECT_EQ(a.kernel_evaluations, b.kernel_evaluations) << ff;
  }
}

// A method that records the threads running its row's blocks. Every block after the first
// (which row_in_parallel runs on the calling thread before it splits the rest) waits, up to 20 s,
// until a second thread has run a block: on a loaded machine a worker may take a while to be
// scheduled, but unless the row really is split, no second thread ever comes and the test fails.
class TwoThreadMethod final : public FormFactorMethod {
 public:
  std::string name() const override { return "two-thread"; }
  std::string parameters() const override { return ""; }
  double stated_row_sum_error(std::string* basis) const override {
    if (basis) *basis = "two-thread: rows of integers, no error";
    return 0.0;
  }
  void row(size_t i, std::span<double> out, RowCost& cost) const override {
    for (size_t j = 0; j < out.size(); ++j) out[j] = double(i + j);
    cost.kernel_evaluations += out.size();
  }
  bool row_part(size_t i, size_t lo, size_t hi, std::span<double> out,
                RowCost& cost) const override {
    {
      std::lock_guard lock(mutex_);
      threads_.insert(std::this_thread::get_id());
    }
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (lo > 0 && threads_seen() < 2 && std::chrono::steady_clock::now() < until)
      std::this_thread::yield();
    for (size_t j = lo; j < hi; ++j) out[j] = double(i + j);
    cost.kernel_evaluations += hi - lo;
    return true;
  }
  size_t threads_seen() const {
    std::lock_guard lock(mutex_);
    return threads_.size();
  }

 private:
  mutable std::mutex mutex_;
  mutable std::set<std::thread::id> threads_;
};

TEST(ParallelRow, SharesARowBetweenThreads) {
  TwoThreadMethod method;
  const size_t n = 16 * kRowBlock;
  std::vector<double> out(n);
  RowCost cost;
  on_threads(2, [&] { row_in_parallel(method, 3, out, cost); });
  EXPECT_EQ(method.threads_seen(), 2u);
  EXPECT_EQ(cost.kernel_evaluations, n);
  for (size_t j = 0; j < n; ++j) ASSERT_EQ(out[j], double(3 + j)) << j;
}

// A sorted-shooting run on rows computed on the fly: the same trace on 1, 2 and 4 threads, and
// the same as on the dense matrix of the same method (build_matrix, double storage).
TEST(ParallelRow, OnTheFlySolverRunIsTheSameBitsOnOneTwoFourThreads) {
  auto p = make_problem("cornell", 3, "raycast");
  const System on_the_fly(p->scene, p->mesh, *p->method);
  BuildReport report;
  const FormFactorMatrix matrix =
      build_matrix(*p->method, p->mesh.size(), Precision::kDouble, report);
  const System cached(p->scene, p->mesh, matrix);
  auto run = [&](const System& system) {
    ParamBag bag;
    auto solver = make_solver("sorted-shooting", bag);
    solver->init(system);
    for (int k = 0; k < 60; ++k) solver->step();
    return solver->solution();
  };
  const Radiosity expected = run(cached);
  for (int threads : {1, 2, 4}) {
    Radiosity B;
    on_threads(threads, [&] { B = run(on_the_fly); });
    EXPECT_TRUE(same_bits(expected.raw(), B.raw())) << threads << " threads";
  }
}

// A long RGB shot with fused selection and coverage, split over threads (kernels.h): the same
// dB, coverage and argmax as the unsplit pass, on 1, 2 and 4 threads. The largest priority is
// planted twice, so the tie rule (lowest index) is tested across the pieces.
TEST(ParallelShot, SameBitsAsTheUnsplitShotOnOneTwoFourThreads) {
  const size_t n = 5 * kernels::kShotChunk + 123;
  Pcg32 rng(9);
  std::vector<float> F(n);
  std::vector<double> inverse_area(n), area(n), start[3], rho[3];
  for (size_t j = 0; j < n; ++j) {
    F[j] = float(1e-4 * rng.next_double());
    area[j] = 0.5 + rng.next_double();
    inverse_area[j] = 1.0 / area[j];
  }
  for (int c = 0; c < 3; ++c) {
    start[c].resize(n);
    rho[c].resize(n);
    for (size_t j = 0; j < n; ++j) {
      start[c][j] = 1e-3 * rng.next_double();
      rho[c][j] = 0.3 + 0.6 * rng.next_double();
    }
  }
  // Two receivers, in different pieces, end with the same largest priority.
  for (size_t j : {size_t(kernels::kShotChunk + 5), size_t(3 * kernels::kShotChunk + 7)}) {
    F[j] = 0.0f;
    area[j] = 1000.0;
    inverse_area[j] = 1.0 / area[j];
    for (int c = 0; c < 3; ++c) start[c][j] = 1.0;
  }
  const double k[3] = {0.1, 0.2, 0.3};
  struct Result {
    std::vector<double> dB[3], coverage;
    kernels::Argmax best;
  };
  auto shoot = [&]() {
    Result r;
    kernels::ShotTargets t;
    t.channels = 3;
    for (int c = 0; c < 3; ++c) {
      r.dB[c] = start[c];
      t.unshot[c] = r.dB[c].data();
      t.reflectance[c] = rho[c].data();
    }
    r.coverage.assign(n, 0.0);
    t.coverage = r.coverage.data();
    t.inverse_area = inverse_area.data();
    t.area = area.data();
    r.best = kernels::shoot(F.data(), 3, n, k, 2.0, t, true);
    return r;
  };
  const size_t previous = kernels::set_parallel_shot_minimum(SIZE_MAX);
  const Result serial = shoot();
  kernels::set_parallel_shot_minimum(2 * kernels::kShotChunk);  // split this shot
  ASSERT_EQ(serial.best.index, kernels::kShotChunk + 5);
  for (int threads : {1, 2, 4}) {
    Result r;
    on_threads(threads, [&] { r = shoot(); });
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(same_bits(serial.dB[c], r.dB[c])) << threads;
    EXPECT_TRUE(same_bits(serial.coverage, r.coverage)) << threads;
    EXPECT_EQ(r.best.index, serial.best.index) << threads;
    EXPECT_EQ(r.best.value, serial.best.value) << threads;
  }
  kernels::set_parallel_shot_minimum(previous);
}

// I - rho F for a random F with rows summing to ~0.9 (the radiosity system), or a random
// general matrix (pivoting does real work).
Eigen::MatrixXd random_matrix(size_t n, bool radiosity, uint64_t seed) {
  Pcg32 rng(seed);
  Eigen::MatrixXd A(n, n);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      const double u = rng.next_double();
      A(Eigen::Index(i), Eigen::Index(j)) =
          radiosity ? (i == j ? 1.0 : 0.0) - 0.9 * 2.0 * u / double(n) : 2.0 * u - 1.0;
    }
  return A;
}

TEST(DenseLu, SolvesAndIsTheSameBitsOnOneTwoFourThreads) {
  // 700 and 333: not multiples of the panel (128) or tile (256) sizes, so the edges are tested.
  for (auto [n, radiosity] : {std::pair{size_t(700), true}, std::pair{size_t(333), false}}) {
    const Eigen::MatrixXd A = random_matrix(n, radiosity, n);
    std::vector<double> b(n);
    for (size_t i = 0; i < n; ++i) b[i] = 1.0 + double(i % 7);
    std::vector<std::vector<double>> x(3);
    const int counts[] = {1, 2, 4};
    for (int t = 0; t < 3; ++t)
      on_threads(counts[t], [&] {
        BlockedLu lu(n, [&](size_t i, size_t j) { return A(Eigen::Index(i), Eigen::Index(j)); });
        lu.solve(b, x[size_t(t)]);
      });
    EXPECT_TRUE(same_bits(x[0], x[1])) << n;
    EXPECT_TRUE(same_bits(x[0], x[2])) << n;
    // Backward stability of LU with partial pivoting (Higham, Thm 9.5): the residual is within
    // ~ n u ||A|| ||x|| times the growth factor, which is small for these matrices; 10 n u
    // leaves a factor 10 for the growth and the bound's constant.
    const Eigen::Map<const Eigen::VectorXd> xv(x[0].data(), Eigen::Index(n));
    const Eigen::Map<const Eigen::VectorXd> bv(b.data(), Eigen::Index(n));
    const double residual = (A * xv - bv).lpNorm<Eigen::Infinity>();
    const double scale = A.cwiseAbs().rowwise().sum().maxCoeff() * xv.lpNorm<Eigen::Infinity>();
    EXPECT_LE(residual, 10.0 * double(n) * 1.1e-16 * scale) << n;
    // And the same solution as Eigen's LU, to the condition number times that.
    const Eigen::VectorXd eigen = A.partialPivLu().solve(bv);
    const double cond = A.partialPivLu().inverse().cwiseAbs().rowwise().sum().maxCoeff() *
                        A.cwiseAbs().rowwise().sum().maxCoeff();
    EXPECT_LE((eigen - xv).lpNorm<Eigen::Infinity>(),
              cond * 10.0 * double(n) * 1.1e-16 * xv.lpNorm<Eigen::Infinity>())
        << n;
  }
}

TEST(DenseLu, SingularMatrixGivesNonFiniteNotACrash) {
  const size_t n = 300;
  Eigen::MatrixXd A = random_matrix(n, false, 5);
  A.col(17).setZero();
  BlockedLu lu(n, [&](size_t i, size_t j) { return A(Eigen::Index(i), Eigen::Index(j)); });
  std::vector<double> x, b(n, 1.0);
  lu.solve(b, x);
  bool finite = true;
  for (double v : x) finite = finite && std::isfinite(v);
  EXPECT_FALSE(finite);
}

std::string radlab_command(const std::string& arguments) {
  return "timeout 120 " + std::string(RADLAB_BINARY) + " " + arguments;
}

TEST(ThreadsOption, LimitsThreadsAndIsRecordedAndChecked) {
  testing::TempDir dir;
  for (const char* threads : {"1", "2"}) {
    const auto r = testing::run_command(radlab_command(
        std::string("-q --threads ") + threads +
        " solve builtin:cube:rho=0.7 --subdiv 2 --solver gauss-seidel --steps 50 --trace " +
        dir.file(std::string("t") + threads + ".csv")));
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream json(dir.file(std::string("t") + threads + ".run.json"));
    std::stringstream text;
    text << json.rdbuf();
    EXPECT_NE(text.str().find(std::string("\"threads\": ") + threads), std::string::npos)
        << text.str();
  }
  for (const char* bad : {"-1", "two", "1.5", "5000"}) {
    const auto r = testing::run_command(
        radlab_command(std::string("solve builtin:cube --threads ") + bad + " --steps 1"));
    EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find("--threads"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace radlab
