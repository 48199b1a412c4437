// The solver kernels' three instruction paths and two row forms give the same bits:
//   - each vector set (AVX2, AVX-512; a set the CPU lacks is reported skipped) against the scalar
//     versions (kernels.h: the same operations in the same order, sums in the same 16 lanes, no
//     fused multiply-adds), for the gather, the gather-scatter, the priority scan and the dense
//     shot with every option (tests/solvers/flat/shooting_test.cpp also checks the default set's
//     shot against the arithmetic written out), on ranges that start and end off any vector
//     boundary;
//   - a sparse row's stored runs (kernels_row.h) and its dense form, for the gather and the shot
//     (skipping a zero is exact, see kernels_row.h), kernel by kernel and through whole solver
//     runs on a System over a dense and a sparse matrix with the same entries.
// Every comparison is bitwise (memcmp): all of these kernels either do elementwise arithmetic or
// reduce in one fixed order shared by every path, so no tolerance is justified.
#include "solvers/kernels/kernels.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/random.h"
#include "formfactor/matrix/matrix.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/registry.h"
#include "solvers/system.h"

namespace radlab {
namespace {

bool same_bits(const double* a, const double* b, size_t n) {
  return std::memcmp(a, b, n * sizeof(double)) == 0;
}

// A row of n with gaps: runs of stored values (some of them zero, as a sparse row may store
// short gaps as zeros) separated by unstored stretches, one of them at the start.
std::vector<double> row_with_gaps(size_t n, Pcg32& rng) {
  std::vector<double> row(n, 0.0);
  size_t j = 5;
  while (j < n) {
    const size_t stored = 1 + size_t(rng.next_double() * 60.0);
    for (size_t q = j; q < std::min(n, j + stored); ++q)
      row[q] = rng.next_double() < 0.1 ? 0.0 : 1e-3 * (0.1 + rng.next_double());
    j += stored + 1 + size_t(rng.next_double() * 40.0);
  }
  return row;
}

// Tests run once per vector set, each against the scalar kernels; a set this CPU lacks is
// skipped with a message (not passed). The default kernels are restored when a test ends.
class VectorSet : public ::testing::TestWithParam<kernels::KernelSet> {
 protected:
  void SetUp() override {
    if (!kernels::kernels_available(GetParam()))
      GTEST_SKIP() << "no " << kernels::kernel_set_name(GetParam()) << " on this CPU";
  }
  void TearDown() override { kernels::use_vector_kernels(true); }
  // The scalar kernels (false) or this test's vector set (true).
  static void use(bool vector) {
    ASSERT_TRUE(kernels::use_kernels(vector ? GetParam() : kernels::KernelSet::kScalar));
  }
};

std::string set_name(const ::testing::TestParamInfo<kernels::KernelSet>& param) {
  return kernels::kernel_set_name(param.param);
}

INSTANTIATE_TEST_SUITE_P(Kernels, VectorSet,
                         ::testing::Values(kernels::KernelSet::kAvx2, kernels::KernelSet::kAvx512),
                         set_name);

TEST_P(VectorSet, GatherAndGatherScatterScalarEqualsVector) {
  Pcg32 rng(3);
  for (size_t n : {1u, 15u, 16u, 17u, 333u, 1000u}) {
    std::vector<float> Ff(n);
    std::vector<double> Fd(n);
    for (size_t j = 0; j < n; ++j) {
      Fd[j] = rng.next_double() * 1e-2;
      Ff[j] = float(Fd[j]);
    }
    for (int C : {1, 3}) {
      Radiosity x(C, n);
      for (double& v : x.raw()) v = rng.next_double() - 0.3;  // negatives: the clamp matters
      const double a[3] = {0.3, -1.7, 2.5};
      for (bool use_float : {true, false})
        for (bool clamp : {false, true}) {
          double out[2][3] = {};
          for (int vector : {0, 1}) {
            use(vector);
            if (use_float)
              kernels::gather(Ff.data(), x, out[vector], clamp);
            else
              kernels::gather(Fd.data(), x, out[vector], clamp);
          }
          EXPECT_TRUE(same_bits(out[0], out[1], size_t(C)))
              << "gather n=" << n << " C=" << C << " float=" << use_float << " clamp=" << clamp;
        }
      for (bool use_float : {true, false}) {
        double out[2][3] = {};
        Radiosity z[2] = {Radiosity(C, n), Radiosity(C, n)};
        for (int vector : {0, 1}) {
          for (double& v : z[vector].raw()) v = 0.5;
          use(vector);
          if (use_float)
            kernels::gather_scatter(Ff.data(), x, out[vector], z[vector], a);
          else
            kernels::gather_scatter(Fd.data(), x, out[vector], z[vector], a);
        }
        EXPECT_TRUE(same_bits(out[0], out[1], size_t(C))) << "gather_scatter n=" << n;
        EXPECT_TRUE(same_bits(z[0].raw().data(), z[1].raw().data(), z[0].raw().size()))
            << "gather_scatter's scatter n=" << n;
      }
    }
  }
}

// Two rows gathered in one pass (Jacobi's and conjugate gradients' dense rows) give each row's
// single gather bits: on this set (for RGB under an explicit AVX2, two single gathers; under
// AVX-512, the paired loop) and on the scalar path.
TEST_P(VectorSet, GatherPairEqualsTwoScalarGathers) {
  Pcg32 rng(13);
  for (size_t n : {1u, 15u, 16u, 17u, 333u, 1000u}) {
    std::vector<float> Ff[2] = {std::vector<float>(n), std::vector<float>(n)};
    std::vector<double> Fd[2] = {std::vector<double>(n), std::vector<double>(n)};
    for (int r = 0; r < 2; ++r)
      for (size_t j = 0; j < n; ++j) {
        Fd[r][j] = rng.next_double() * 1e-2;
        Ff[r][j] = float(Fd[r][j]);
      }
    for (int C : {1, 3}) {
      Radiosity x(C, n);
      for (double& v : x.raw()) v = rng.next_double() - 0.3;
      for (bool use_float : {true, false}) {
        double want[2][3] = {}, got[2][3] = {};
        use(false);
        for (int r = 0; r < 2; ++r)
          use_float ? kernels::gather(Ff[r].data(), x, want[r])
                    : kernels::gather(Fd[r].data(), x, want[r]);
        for (int vector : {0, 1}) {
          use(vector);
          use_float ? kernels::gather_pair(Ff[0].data(), Ff[1].data(), x, got[0], got[1])
                    : kernels::gather_pair(Fd[0].data(), Fd[1].data(), x, got[0], got[1]);
          for (int r = 0; r < 2; ++r)
            EXPECT_TRUE(same_bits(want[r], got[r], size_t(C)))
                << "gather_pair row " << r << " n=" << n << " C=" << C << " float=" << use_float
                << " vector=" << vector;
        }
      }
    }
  }
}

// The default kernels: AVX2 for every kernel, but the RGB pair on AVX-512 where the CPU has it
// (kernels.cpp, pair_set). The same bits as the scalar gathers either way.
TEST(KernelsDispatch, DefaultGatherPairEqualsScalarGathers) {
  Pcg32 rng(17);
  const size_t n = 1001;
  std::vector<float> F0(n), F1(n);
  for (size_t j = 0; j < n; ++j) {
    F0[j] = float(rng.next_double() * 1e-2);
    F1[j] = float(rng.next_double() * 1e-2);
  }
  for (int C : {1, 3}) {
    Radiosity x(C, n);
    for (double& v : x.raw()) v = rng.next_double();
    double want[2][3] = {}, got[2][3] = {};
    ASSERT_TRUE(kernels::use_kernels(kernels::KernelSet::kScalar));
    kernels::gather(F0.data(), x, want[0]);
    kernels::gather(F1.data(), x, want[1]);
    kernels::use_vector_kernels(true);
    kernels::gather_pair(F0.data(), F1.data(), x, got[0], got[1]);
    EXPECT_TRUE(same_bits(want[0], got[0], size_t(C))) << "C=" << C;
    EXPECT_TRUE(same_bits(want[1], got[1], size_t(C))) << "C=" << C;
  }
}

// The shot's arrays, each test case starting from the same values.
struct ShotState {
  std::vector<double> dB, coverage, offset;
  std::vector<double> rho, area, inverse_area;
  kernels::ShotTargets targets(int C, size_t n, bool coverage_on, bool offsets) {
    kernels::ShotTargets t;
    t.channels = C;
    for (int c = 0; c < C; ++c) {
      t.unshot[c] = dB.data() + size_t(c) * n;
      t.reflectance[c] = rho.data() + size_t(c) * n;
      if (offsets) t.offset[c] = offset.data() + size_t(c) * n;
    }
    t.area = area.data();
    t.inverse_area = inverse_area.data();
    if (coverage_on) t.coverage = coverage.data();
    return t;
  }
};

ShotState random_state(size_t n, Pcg32& rng) {
  ShotState s;
  s.dB.resize(3 * n);
  s.offset.resize(3 * n);
  s.rho.resize(3 * n);
  s.coverage.resize(n);
  s.area.resize(n);
  s.inverse_area.resize(n);
  for (size_t j = 0; j < 3 * n; ++j) {
    s.dB[j] = rng.next_double() - 0.2;
    s.offset[j] = 0.1 * rng.next_double();
    s.rho[j] = rng.next_double();
  }
  for (size_t j = 0; j < n; ++j) {
    s.coverage[j] = rng.next_double();
    s.area[j] = 0.01 + rng.next_double();
    s.inverse_area[j] = 1.0 / s.area[j];
  }
  return s;
}

void expect_same(const ShotState& a, const ShotState& b, const kernels::Argmax& ma,
                 const kernels::Argmax& mb, const std::string& what) {
  EXPECT_TRUE(same_bits(a.dB.data(), b.dB.data(), a.dB.size())) << what << ": dB";
  EXPECT_TRUE(same_bits(a.coverage.data(), b.coverage.data(), a.coverage.size()))
      << what << ": coverage";
  EXPECT_TRUE(same_bits(&ma.value, &mb.value, 1)) << what << ": the maximum";
  EXPECT_EQ(ma.index, mb.index) << what << ": its index";
}

// The scan for the largest priority (after gathers, and after a sparse row's shot): the same value
// and lowest index on both paths, with ties (equal dB and areas repeated along the array).
TEST_P(VectorSet, MaxPriorityScalarEqualsVector) {
  Pcg32 rng(29);
  const size_t n = 301;
  ShotState state = random_state(n, rng);
  for (size_t j = 150; j < n; ++j) {  // the second half repeats the first: every maximum is tied
    state.area[j] = state.area[j - 150];
    for (int c = 0; c < 3; ++c) state.dB[size_t(c) * n + j] = state.dB[size_t(c) * n + j - 150];
  }
  for (int C : {1, 3})
    for (bool offsets : {false, true})
      for (auto [lo, hi] : {std::pair<size_t, size_t>{0, n}, {3, 200}, {151, n}, {5, 6}, {9, 9}}) {
        const kernels::ShotTargets t = state.targets(C, n, false, offsets);
        use(false);
        const kernels::Argmax want = kernels::max_priority(lo, hi, t);
        use(true);
        const kernels::Argmax got = kernels::max_priority(lo, hi, t);
        EXPECT_TRUE(same_bits(&want.value, &got.value, 1))
            << "C=" << C << " [" << lo << ", " << hi << ")";
        EXPECT_EQ(want.index, got.index) << "C=" << C << " [" << lo << ", " << hi << ")";
      }
}

// The dense shot, every option (channels, float or double rows, selection, coverage, offsets,
// reflectance runs), on ranges cut off every vector and alignment boundary (the AVX-512 path
// aligns its stores to 64 bytes and steps 16 receivers at a time, AVX2 32 bytes and 8), with a
// tie for the largest priority planted twice in a block and across blocks.
TEST_P(VectorSet, DenseShotScalarEqualsVector) {
  Pcg32 rng(41);
  const size_t n = 333;
  std::vector<float> Ff(n);
  std::vector<double> Fd(n);
  for (size_t j = 0; j < n; ++j) {
    Fd[j] = rng.next_double() * 1e-2;
    Ff[j] = float(Fd[j]);
  }
  ShotState start = random_state(n, rng);
  for (size_t j : {40u, 45u, 200u}) {  // equal, largest priorities (k = 0 below keeps them)
    start.area[j] = 50.0;
    for (int c = 0; c < 3; ++c) start.dB[size_t(c) * n + j] = 2.0;
  }
  const std::vector<kernels::ReflectanceRun> runs = {
      {7, {0.3, 0.4, 0.5}}, {100, {0.9, 0.1, 0.2}}, {101, {0.5, 0.5, 0.5}}, {n, {0.7, 0.8, 0.6}}};
  for (int C : {1, 3})
    for (bool use_float : {true, false})
      for (bool select : {false, true})
        for (bool coverage : {false, true})
          for (bool offsets : {false, true})
            for (bool with_runs : {false, true})
              for (bool zero_k : {false, true})
                for (auto [lo, hi] : {std::pair<size_t, size_t>{0, n},
                                      {1, n},
                                      {3, 300},
                                      {9, 70},
                                      {17, 18},
                                      {100, 333},
                                      {5, 5}}) {
                  ShotState a = start, b = start;
                  const double k[3] = {zero_k ? 0.0 : 0.7, zero_k ? 0.0 : -0.3, zero_k ? 0.0 : 1.9};
                  kernels::Argmax m[2];
                  for (int vector : {0, 1}) {
                    ShotState& s = vector ? b : a;
                    kernels::ShotTargets t = s.targets(C, n, coverage, offsets);
                    if (with_runs) {
                      t.runs = runs.data();
                      t.run_count = runs.size();
                    }
                    use(vector);
                    m[vector] = use_float ? kernels::shoot(Ff.data(), lo, hi, k, 0.37, t, select)
                                          : kernels::shoot(Fd.data(), lo, hi, k, 0.37, t, select);
                  }
                  expect_same(a, b, m[0], m[1],
                              "C=" + std::to_string(C) + " float=" + std::to_string(use_float) +
                                  " select=" + std::to_string(select) + " coverage=" +
                                  std::to_string(coverage) + " offsets=" + std::to_string(offsets) +
                                  " runs=" + std::to_string(with_runs) +
                                  " k=0: " + std::to_string(zero_k) + " [" + std::to_string(lo) +
                                  ", " + std::to_string(hi) + ")");
                }
}

// A sparse matrix's row and its dense form: gather and shot, the scalar path and this vector
// set, every option of the shot, on ranges cut inside runs and inside gaps.
TEST_P(VectorSet, SparseRowEqualsDenseRow) {
  Pcg32 rng(17);
  const size_t n = 700;
  for (Precision precision : {Precision::kFloat, Precision::kDouble}) {
    FormFactorMatrix dense(n, precision), sparse(n, precision, Layout::kSparse);
    const std::vector<double> values = row_with_gaps(n, rng);
    dense.set_row(0, values);
    sparse.set_row(0, values);
    ASSERT_FALSE(sparse.whole_row(0)) << "the test row must be stored in runs";
    ASSERT_TRUE(identical_entries(dense, sparse));
    const FormFactorMatrix::SparseRow& stored = sparse.sparse_row(0);
    const bool f32 = precision == Precision::kFloat;
    const kernels::RunRow<float> rf{stored.run.data(), stored.run.size() / 2, stored.f32.data(),
                                    stored.f32.size()};
    const kernels::RunRow<double> rd{stored.run.data(), stored.run.size() / 2, stored.f64.data(),
                                     stored.f64.size()};
    for (size_t j = 0; j < n; ++j)
      ASSERT_EQ(f32 ? double(rf[j]) : rd[j], dense.at(0, j)) << "RunRow[" << j << "]";
    const ShotState start = random_state(n, rng);
    for (int vector : {0, 1}) {
      use(vector);
      for (int C : {1, 3}) {
        Radiosity x(C, n);
        for (double& v : x.raw()) v = rng.next_double() - 0.3;
        for (bool clamp : {false, true}) {
          double want[3] = {}, got[3] = {};
          if (f32) {
            kernels::gather(dense.row_f32(0), x, want, clamp);
            kernels::gather(rf, x, got, clamp);
          } else {
            kernels::gather(dense.row_f64(0), x, want, clamp);
            kernels::gather(rd, x, got, clamp);
          }
          EXPECT_TRUE(same_bits(want, got, size_t(C)))
              << "gather C=" << C << " clamp=" << clamp << " vector=" << vector;
        }
        const double k[3] = {0.7, -0.3, 1.9};
        for (bool select : {false, true})
          for (bool coverage : {false, true})
            for (bool offsets : {false, true})
              for (auto [lo, hi] : {std::pair<size_t, size_t>{0, n}, {0, 3}, {7, 450}, {101, n}}) {
                ShotState a = start, b = start;
                const kernels::ShotTargets ta = a.targets(C, n, coverage, offsets);
                const kernels::ShotTargets tb = b.targets(C, n, coverage, offsets);
                const kernels::Argmax ma =
                    f32 ? kernels::shoot(dense.row_f32(0), lo, hi, k, 0.37, ta, select)
                        : kernels::shoot(dense.row_f64(0), lo, hi, k, 0.37, ta, select);
                const kernels::Argmax mb = f32 ? kernels::shoot(rf, lo, hi, k, 0.37, tb, select)
                                               : kernels::shoot(rd, lo, hi, k, 0.37, tb, select);
                expect_same(a, b, ma, mb,
                            "shot C=" + std::to_string(C) + " [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + ") select=" + std::to_string(select) +
                                " coverage=" + std::to_string(coverage) + " offsets=" +
                                std::to_string(offsets) + " vector=" + std::to_string(vector));
              }
      }
    }
  }
}

// A sparse row's shot with the selection fused (the runs ranked while they are shot, the gaps
// scanned) returns the lowest index among tied largest priorities wherever the ties fall: in a
// gap before a run, in a run before a gap, in two runs, after the last run. k = 0 makes the shot
// add +0 to every receiver, so the priorities are the ones set here and the expected index is
// known without running any kernel. The scalar path and this vector set, with and without
// reflectance runs.
TEST_P(VectorSet, SparseShotSelectionTakesLowestTiedIndex) {
  Pcg32 rng(29);
  const size_t n = 400;
  FormFactorMatrix sparse(n, Precision::kFloat, Layout::kSparse);
  sparse.set_row(0, row_with_gaps(n, rng));
  const FormFactorMatrix::SparseRow& stored = sparse.sparse_row(0);
  const kernels::RunRow<float> row{stored.run.data(), stored.run.size() / 2, stored.f32.data(),
                                   stored.f32.size()};
  std::vector<bool> in_run(n, false);
  for (size_t r = 0; r < row.runs; ++r)
    for (size_t q = 0; q < row.count(r); ++q) in_run[row.first(r) + q] = true;
  std::vector<size_t> runs, gaps;  // columns inside the runs and in the gaps
  for (size_t j = 0; j < n; ++j) (in_run[j] ? runs : gaps).push_back(j);
  ASSERT_GT(runs.size(), 100u);
  ASSERT_GT(gaps.size(), 100u);
  // Pairs of columns given the same, largest priority: gap then run, run then gap, two runs far
  // apart (different runs), two gaps, the last gap column with a later tie nowhere, none (all
  // priorities tied: the first column of the range wins).
  const std::vector<std::pair<size_t, size_t>> ties = {
      {gaps[3], runs[40]},       {runs[5], gaps[60]},        {runs[10], runs[runs.size() - 2]},
      {gaps[1], gaps.back()},    {gaps.back(), gaps.back()}, {kernels::kNone, kernels::kNone},
      {runs.back(), gaps.back()}};
  const kernels::ReflectanceRun whole{n, {0.5, 0.6, 0.7}};
  const double k[3] = {0.0, 0.0, 0.0};
  for (int vector : {0, 1}) {
    use(vector);
    for (int C : {1, 3})
      for (bool reflectance_runs : {false, true})
        for (auto [p, q] : ties)
          for (auto [lo, hi] : {std::pair<size_t, size_t>{0, n}, {2, n - 1}}) {
            std::vector<double> dB(3 * n, 0.25), rho(3 * n, 0.5), area(n, 1.0), inverse(n, 1.0);
            size_t want = lo;
            if (p != kernels::kNone) {
              for (int c = 0; c < C; ++c) dB[size_t(c) * n + p] = dB[size_t(c) * n + q] = 1.0;
              want = std::min(p, q) >= lo && std::min(p, q) < hi ? std::min(p, q) : std::max(p, q);
              if (want < lo || want >= hi) continue;
            }
            kernels::ShotTargets t;
            t.channels = C;
            for (int c = 0; c < C; ++c) {
              t.unshot[c] = dB.data() + size_t(c) * n;
              t.reflectance[c] = rho.data() + size_t(c) * n;
            }
            t.area = area.data();
            t.inverse_area = inverse.data();
            if (reflectance_runs) {
              t.runs = &whole;
              t.run_count = 1;
            }
            const kernels::Argmax m = kernels::shoot(row, lo, hi, k, 0.0, t, true);
            const double top = p != kernels::kNone ? double(C) * 1.0 : double(C) * 0.25;
            EXPECT_EQ(m.index, want)
                << "ties at " << p << ", " << q << " C=" << C << " vector=" << vector
                << " runs=" << reflectance_runs << " [" << lo << ", " << hi << ")";
            EXPECT_EQ(m.value, top);
          }
  }
}

// A dense and a sparse matrix with the same reciprocal entries, A_i F_ij = A_j F_ji = g_ij with
// g_ij = scale u min(A_i, A_j) / n (u uniform in [0, 1) from `seed`); with gaps, zero for a third
// of the pairs in blocks (culled or occluded pairs), so that sparse rows are stored in runs.
struct SameEntries {
  FormFactorMatrix dense, sparse;
};
SameEntries reciprocal_matrices(const Mesh& mesh, uint64_t seed, double scale, bool gaps) {
  const size_t n = mesh.size();
  SameEntries m{FormFactorMatrix(n, Precision::kFloat),
                FormFactorMatrix(n, Precision::kFloat, Layout::kSparse)};
  Pcg32 rng(seed);
  std::vector<std::vector<double>> rows(n, std::vector<double>(n, 0.0));
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      if (gaps && (i / 7 + j / 5) % 3 == 0) continue;
      const double g = scale * rng.next_double() * std::min(mesh.area[i], mesh.area[j]) / double(n);
      rows[i][j] = g / mesh.area[i];
      rows[j][i] = g / mesh.area[j];
    }
  for (size_t i = 0; i < n; ++i) {
    m.dense.set_row(i, rows[i]);
    m.sparse.set_row(i, rows[i]);
  }
  return m;
}

// Whole runs: the solvers that read rows through System::with_compact_row give the same
// solution bits on a sparse matrix as on the dense one with the same entries.
TEST(KernelsDispatch, SolversOnSparseMatrixEqualDense) {
  for (const std::string scene_name : {"cornell", "cube"}) {
    Scene scene = make_builtin_scene(scene_name);
    validate_scene(scene);
    const Mesh mesh = build_mesh(scene, {3, 0.0});
    const size_t n = mesh.size();
    // Reciprocal entries with gaps, rows summing to ~0.8.
    const SameEntries m = reciprocal_matrices(mesh, 5, 2.4, /*gaps=*/true);
    const FormFactorMatrix &dense = m.dense, &sparse = m.sparse;
    ASSERT_TRUE(identical_entries(dense, sparse));
    size_t partial = 0;
    for (size_t i = 0; i < n; ++i) partial += sparse.whole_row(i) ? 0 : 1;
    ASSERT_GT(partial, n / 2) << "most rows must be stored in runs for this test to mean much";
    const System on_dense(scene, mesh, dense), on_sparse(scene, mesh, sparse);
    const std::vector<std::pair<std::string, std::vector<std::string>>> solvers = {
        {"jacobi", {}},
        {"gauss-seidel", {}},
        {"shooting", {}},
        {"sorted-shooting", {}},
        {"overshooting", {}},
        {"overshooting", {"variant=ambient", "clamp=true"}},
        {"interleaved", {"shots=20", "gathers=15", "max_sessions=2"}},
    };
    for (const auto& [name, params] : solvers) {
      Radiosity result[2];
      for (int k = 0; k < 2; ++k) {
        ParamBag bag = ParamBag::from_assignments(params, name);
        auto solver = make_solver(name, bag);
        solver->init(k == 0 ? on_dense : on_sparse);
        for (int step = 0; step < 300; ++step)
          if (solver->step().finished) break;
        result[k] = solver->solution();
      }
      ASSERT_EQ(result[0].raw().size(), result[1].raw().size());
      EXPECT_TRUE(same_bits(result[0].raw().data(), result[1].raw().data(), result[0].raw().size()))
          << scene_name << ": " << name;
    }
  }
}

// Which set a paired gather runs on (kernels.h, gather_pair_kernels): grey pairs on the active
// set; RGB pairs on AVX-512 wherever the CPU has it and it is permitted (the default included),
// on the active set where it is not (an explicit AVX2 or scalar choice).
TEST(KernelsDispatch, PairedGatherSetFollowsTheDocumentedRule) {
  using kernels::KernelSet;
  const bool avx512 = kernels::kernels_available(KernelSet::kAvx512);
  ASSERT_TRUE(kernels::use_kernels(KernelSet::kScalar));
  EXPECT_EQ(kernels::gather_pair_kernels(3), KernelSet::kScalar);
  EXPECT_EQ(kernels::gather_pair_kernels(1), KernelSet::kScalar);
  if (kernels::use_kernels(KernelSet::kAvx2)) {
    EXPECT_EQ(kernels::gather_pair_kernels(3), KernelSet::kAvx2);
    EXPECT_EQ(kernels::gather_pair_kernels(1), KernelSet::kAvx2);
  }
  kernels::use_vector_kernels(true);
  const KernelSet active = kernels::kernels_in_use();
  EXPECT_EQ(kernels::gather_pair_kernels(1), active);
  const char* env = std::getenv("RADLAB_KERNELS");
  const std::string choice = env ? env : "";
  if (avx512 && choice != "avx2" && choice != "scalar") {
    EXPECT_EQ(kernels::gather_pair_kernels(3), KernelSet::kAvx512);
  } else {
    EXPECT_EQ(kernels::gather_pair_kernels(3), active);
  }
}

// Jacobi, conjugate gradients and interleaving's gathers read two dense rows a pass
// (System::with_dense_rows); on a sparse matrix with the same entries they read one row at a
// time. Every step's solution is the same bits, and the same rows have been counted after every
// step (Jacobi charges a paired row at the step that uses it).
TEST(KernelsDispatch, PairedRowsGiveEveryStepsBits) {
  for (const std::string scene_name : {"cornell", "cube"}) {
    Scene scene = make_builtin_scene(scene_name);
    validate_scene(scene);
    const Mesh mesh = build_mesh(scene, {3, 0.0});
    const size_t n = mesh.size();
    const SameEntries m = reciprocal_matrices(mesh, 23, 1.6, /*gaps=*/false);
    const FormFactorMatrix &dense = m.dense, &sparse = m.sparse;
    const System on_dense(scene, mesh, dense), on_sparse(scene, mesh, sparse);
    const std::vector<std::pair<std::string, std::vector<std::string>>> solvers = {
        {"jacobi", {}},
        {"conjugate-gradient", {}},
        // Gathering sessions of 7 (odd: the last gather of a session goes alone).
        {"interleaved", {"shots=10", "gathers=7", "max_sessions=2"}},
    };
    for (const auto& [name, params] : solvers) {
      ParamBag bags[2] = {ParamBag::from_assignments(params, name),
                          ParamBag::from_assignments(params, name)};
      auto paired = make_solver(name, bags[0]);
      auto single = make_solver(name, bags[1]);
      on_dense.reset_counters();
      on_sparse.reset_counters();
      paired->init(on_dense);
      single->init(on_sparse);
      // Jacobi over two sweeps (odd n or not), interleaved over six sessions of each kind.
      const size_t steps = name == "jacobi" ? 2 * n + 1 : name == "interleaved" ? 102 : 6;
      for (size_t step = 0; step < steps; ++step) {
        const bool done = paired->step().finished;
        EXPECT_EQ(done, single->step().finished);
        const Radiosity &a = paired->solution(), &b = single->solution();
        ASSERT_TRUE(same_bits(a.raw().data(), b.raw().data(), a.raw().size()))
            << scene_name << ": " << name << " differs after step " << step;
        EXPECT_EQ(on_dense.rows_used(), on_sparse.rows_used()) << name << " step " << step;
        if (done) break;
      }
    }
  }
}

}  // namespace
}  // namespace radlab
