// Memory (issue 13, targets 3 and 6): the sparse layout of FormFactorMatrix holds the same
// numbers as the dense one, costs nothing for culled or occluded pairs, round-trips through the
// cache, and gives the solvers and the certified reference the same results bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include "core/error.h"
#include "core/limits.h"
#include "experiments/problem/problem.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"
#include "solvers/reference/reference.h"
#include "solvers/registry.h"
#include "solvers/system.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// Rows of every shape the run encoder meets: empty, full, single entries at both ends, gaps of
// every length around the merge threshold, random fill.
std::vector<std::vector<double>> test_rows(size_t n) {
  std::vector<std::vector<double>> rows;
  rows.emplace_back(n, 0.0);
  rows.emplace_back(n, 0.25);
  for (size_t at : {size_t(0), n - 1}) {
    rows.emplace_back(n, 0.0);
    rows.back()[at] = 0.5;
  }
  for (size_t gap = 1; gap <= 4; ++gap) {
    std::vector<double> row(n, 0.0);
    for (size_t j = 0; j < n; j += gap + 1) row[j] = 0.125 * double(j + 1);
    rows.push_back(row);
  }
  std::mt19937_64 random(13);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (double fill : {0.05, 0.3, 0.6, 0.9}) {
    std::vector<double> row(n, 0.0);
    for (double& v : row)
      if (uniform(random) < fill) v = uniform(random);
    rows.push_back(row);
  }
  return rows;
}

FormFactorMatrix dense_copy(const FormFactorMatrix& m) {
  FormFactorMatrix out(m.size(), m.precision());
  for (size_t i = 0; i < m.size(); ++i)
    m.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < m.size(); ++j) out.set(i, j, double(row[j]));
    });
  return out;
}

TEST(SparseLayout, RowsReadBackExactlyInBothPrecisions) {
  const size_t n = 37;
  const auto rows = test_rows(n);
  for (Precision precision : {Precision::kFloat, Precision::kDouble}) {
    FormFactorMatrix dense(rows.size(), precision), sparse(rows.size(), precision, Layout::kSparse);
    ASSERT_TRUE(sparse.sparse());
    // Square: pad the rows to rows.size() columns.
    const size_t m = rows.size();
    ASSERT_GE(n, m);
    for (size_t i = 0; i < m; ++i) {
      std::vector<double> row(rows[i].begin(), rows[i].begin() + long(m));
      dense.set_row(i, row);
      sparse.set_row(i, row);
    }
    for (size_t i = 0; i < m; ++i) {
      for (size_t j = 0; j < m; ++j) ASSERT_EQ(sparse.at(i, j), dense.at(i, j)) << i << "," << j;
      // visit_row twice: the scratch row is cleared between visits.
      for (int pass = 0; pass < 2; ++pass)
        sparse.visit_row(i, [&](const auto* row) {
          for (size_t j = 0; j < m; ++j) ASSERT_EQ(double(row[j]), dense.at(i, j));
        });
    }
    // In-place and inserting writes.
    sparse.set(3, 0, 0.75);
    dense.set(3, 0, 0.75);
    sparse.set(5, 7, 0.0);
    dense.set(5, 7, 0.0);
    for (size_t i = 0; i < m; ++i)
      for (size_t j = 0; j < m; ++j) ASSERT_EQ(sparse.at(i, j), dense.at(i, j));
    EXPECT_LE(sparse.bytes(), dense.bytes() + m * 8);
  }
}

// Two closed unit cubes back to back (a wall splits a 2 x 1 x 1 room in two), each lit by its
// ceiling: no pair across the wall sees the other, and no pair on one face either.
std::string split_room_mgf() {
  std::string text = "m wall =\n c\n rd .6\nm lamp =\n c\n rd .6\n ed 10\n";
  int vertex = 0;
  auto face = [&](std::vector<Vec3> corners, const char* material) {
    std::string names;
    text += std::string("m ") + material + "\n";
    for (const Vec3& c : corners) {
      const std::string name = "v" + std::to_string(vertex++);
      char line[120];
      std::snprintf(line, sizeof line, "v %s =\n p %g %g %g\n", name.c_str(), c.x, c.y, c.z);
      text += line;
      names += " " + name;
    }
    text += "f" + names + "\n";
  };
  for (double x0 : {0.0, 1.0}) {
    const double x1 = x0 + 1.0;
    // Counter-clockwise seen from inside the cube (normals inward).
    face({{x0, 0, 0}, {x1, 0, 0}, {x1, 1, 0}, {x0, 1, 0}}, "wall");  // floor, +z
    face({{x0, 0, 1}, {x0, 1, 1}, {x1, 1, 1}, {x1, 0, 1}}, "lamp");  // ceiling, -z
    face({{x0, 0, 0}, {x0, 0, 1}, {x1, 0, 1}, {x1, 0, 0}}, "wall");  // y = 0, +y
    face({{x0, 1, 0}, {x1, 1, 0}, {x1, 1, 1}, {x0, 1, 1}}, "wall");  // y = 1, -y
    face({{x0, 0, 0}, {x0, 1, 0}, {x0, 1, 1}, {x0, 0, 1}}, "wall");  // x = x0, +x
    face({{x1, 0, 0}, {x1, 0, 1}, {x1, 1, 1}, {x1, 1, 0}}, "wall");  // x = x1, -x
  }
  return text;
}

std::unique_ptr<Problem> split_room(const testing::TempDir& dir, RowMode rows, bool reference) {
  ProblemSpec spec;
  spec.scene = dir.write("split.mgf", split_room_mgf());
  spec.mesh.subdivisions = 4;
  spec.row_mode = rows;
  spec.need_reference = reference;
  spec.cache_dir = dir.file("cache");
  return prepare_problem(spec);
}

// Half the pairs are across the wall and a sixth of the rest on one face: about 42% of the pairs
// are non-zero, so the sparse layout stores well under 60% of n^2 doubles (the runs cost 8 bytes
// per visible face and row, under 1% here).
TEST(SparseLayout, SplitRoomStoresUnder60PercentOfDense) {
  testing::TempDir dir;
  auto problem = split_room(dir, RowMode::kCached, true);
  const FormFactorMatrix& F = problem->certified_matrix();
  const size_t n = F.size();
  ASSERT_EQ(n, 12u * 16u);
  ASSERT_EQ(F.precision(), Precision::kDouble);
  const double dense = double(n) * double(n) * sizeof(double);
  EXPECT_LT(double(F.bytes()), 0.6 * dense);
  // Nothing crosses the wall in truth; raycast gives exactly 0 there since the skipped ends of its
  // rays are traced again (tests/formfactor/visibility/corner_leak_test.cpp, docs/formfactors.md
  // "Light through walls at touching corners"). Here only the layout is tested: few entries across,
  // stored as runs.
  size_t leaks = 0;
  for (size_t i = 0; i < n / 2; ++i)
    for (size_t j = n / 2; j < n; ++j) {
      ASSERT_LE(F.at(i, j), 1e-4) << i << " " << j;
      leaks += F.at(i, j) != 0.0;
    }
  EXPECT_LE(leaks, n / 16) << "entries across the wall";
  // The float copy the solvers read is under 60% of n^2 floats too.
  EXPECT_LT(double(problem->matrix.bytes()), 0.6 * double(n) * double(n) * sizeof(float));
}

// The same solver on the sparse matrix and on its dense copy: the same numbers at every step
// (the kernels see the same rows), and the reference of each within the two certified bounds.
TEST(SparseLayout, SolverAndReferenceMatchTheDenseMatrix) {
  testing::TempDir dir;
  auto problem = split_room(dir, RowMode::kCached, true);
  ASSERT_TRUE(problem->matrix.sparse());
  const FormFactorMatrix dense = dense_copy(problem->matrix);
  const FormFactorMatrix dense_certified = dense_copy(problem->certified_matrix());
  System sparse_system(problem->scene(), problem->mesh, problem->matrix);
  System dense_system(problem->scene(), problem->mesh, dense);
  for (const char* name : {"sorted-shooting", "gauss-seidel", "overshooting"}) {
    ParamBag none;
    auto a = make_solver(name, none);
    auto b = make_solver(name, none);
    a->init(sparse_system);
    b->init(dense_system);
    for (int step = 0; step < 300; ++step) {
      a->step();
      b->step();
      ASSERT_TRUE(std::ranges::equal(a->solution().raw(), b->solution().raw()))
          << name << " step " << step;
    }
  }
  System certified_system(problem->scene(), problem->mesh, dense_certified);
  const Reference dense_reference = compute_reference(certified_system, dense_certified);
  const Reference& sparse_reference = *problem->reference;
  const double bound = dense_reference.bound_inf + sparse_reference.bound_inf;
  for (int c = 0; c < dense_reference.B.channels(); ++c)
    for (size_t i = 0; i < problem->mesh.size(); ++i)
      ASSERT_LE(std::abs(dense_reference.B.at(c, i) - sparse_reference.B.at(c, i)), bound);
  EXPECT_LE(sparse_reference.bound_relative, 1e-10);
}

// symmetrise() on the sparse layout adds the entries only F_ji has and gives the dense result
// bit for bit; a raycast matrix of an occluded scene has such one-sided pairs.
TEST(SparseLayout, SymmetriseEqualsTheDenseOneBitForBit) {
  testing::TempDir dir;
  ProblemSpec spec;
  spec.scene = "builtin:cornell";
  spec.mesh.subdivisions = 3;
  spec.ff_set = {"symmetrise=false"};
  spec.need_reference = false;
  spec.precision = Precision::kDouble;
  spec.cache_dir = dir.file("cache");
  auto problem = prepare_problem(spec);
  FormFactorMatrix sparse = problem->matrix;
  ASSERT_TRUE(sparse.sparse());
  FormFactorMatrix dense = dense_copy(sparse);
  symmetrise(sparse, problem->mesh.area);
  symmetrise(dense, problem->mesh.area);
  for (size_t i = 0; i < dense.size(); ++i)
    for (size_t j = 0; j < dense.size(); ++j)
      ASSERT_EQ(sparse.at(i, j), dense.at(i, j)) << i << "," << j;
}

// The cache stores the sparse layout as it is, and a damaged run is refused (never trusted).
TEST(SparseLayout, CacheRoundTripsAndRefusesDamagedRuns) {
  testing::TempDir dir;
  const size_t n = 37;
  const auto rows = test_rows(n);
  for (Precision precision : {Precision::kFloat, Precision::kDouble}) {
    FormFactorMatrix m(n, precision, Layout::kSparse);
    for (size_t i = 0; i < n; ++i) m.set_row(i, rows[i % rows.size()]);
    MatrixCache cache(dir.path());
    MatrixCacheKey key;
    key.text = std::string("memory-test;") + (precision == Precision::kFloat ? "f" : "d");
    key.hash = {hash_bytes(key.text.data(), key.text.size(), 1), 2};
    BuildReport report;
    ASSERT_TRUE(cache.store(key, m, report));
    auto loaded = cache.load(key, nullptr);
    ASSERT_TRUE(loaded);
    ASSERT_TRUE(loaded->sparse());
    ASSERT_EQ(loaded->bytes(), m.bytes());
    for (size_t i = 0; i < n; ++i)
      for (size_t j = 0; j < n; ++j) ASSERT_EQ(loaded->at(i, j), m.at(i, j));
    // A flipped payload byte: refused by the checksum and deleted.
    const std::string file = cache.path(key).string();
    const auto size = std::filesystem::file_size(file);
    ASSERT_GT(size, 200u);
    {
      std::fstream io(file, std::ios::binary | std::ios::in | std::ios::out);
      io.seekg(long(size) - 1);
      const char last = char(io.get());
      io.seekp(long(size) - 1);
      io.put(char(last ^ 1));  // the last value byte: the checksum no longer matches
    }
    EXPECT_FALSE(cache.load(key, nullptr));
    EXPECT_FALSE(std::filesystem::exists(file));  // deleted, to be rebuilt
  }
}

// Rows on the fly with the reference in the cache: the reference is certified with the rows the
// method computes and no n^2 matrix is allocated; a memory limit below n^2 doubles (which every
// dense allocation checks first) does not stop the run, and the certificate matches the one
// computed with the dense matrix (the rows are the same numbers, so the same residual).
TEST(OnTheFly, CachedReferenceNeedsNoDenseMatrix) {
  testing::TempDir dir;
  auto first = split_room(dir, RowMode::kOnTheFly, true);  // builds the matrix, stores B
  ASSERT_TRUE(first->has_matrix());
  const double dense_bytes = double(first->mesh.size()) * double(first->mesh.size()) * 8.0;
  const double saved = limits().memory_gb;
  limits().memory_gb = 0.25 * dense_bytes / 1e9;  // below n^2 floats too
  std::unique_ptr<Problem> second;
  try {
    second = split_room(dir, RowMode::kOnTheFly, true);
  } catch (...) {
    limits().memory_gb = saved;
    throw;
  }
  // A run that needs the dense matrix is refused by the same limit.
  EXPECT_THROW(split_room(dir, RowMode::kCached, true), InputError);
  limits().memory_gb = saved;
  EXPECT_FALSE(second->has_matrix());
  ASSERT_TRUE(second->reference);
  EXPECT_EQ(second->reference->kind, "certified");
  EXPECT_NE(second->reference->system.find("on the fly"), std::string::npos);
  EXPECT_EQ(second->reference->residual_inf, first->reference->residual_inf);
  EXPECT_EQ(second->reference->bound_inf, first->reference->bound_inf);
  EXPECT_TRUE(second->row_sums.ok());
}

// Runs out of order, overlapping or past the row are refused (what a damaged file would give
// the loader after its size checks).
TEST(SparseLayout, MalformedRunsAreRefused) {
  FormFactorMatrix m(8, Precision::kDouble, Layout::kSparse);
  auto row = [](std::vector<uint32_t> run, size_t values) {
    FormFactorMatrix::SparseRow r;
    r.run = std::move(run);
    r.f64.assign(values, 0.5);
    return r;
  };
  EXPECT_NO_THROW(m.set_sparse_row(0, row({1, 0, 5, 2}, 4)));
  EXPECT_EQ(m.at(0, 2), 0.5);
  EXPECT_EQ(m.at(0, 3), 0.0);
  EXPECT_THROW(m.set_sparse_row(1, row({5, 0, 1, 2}, 4)), std::invalid_argument);  // order
  EXPECT_THROW(m.set_sparse_row(1, row({1, 0, 2, 2}, 4)), std::invalid_argument);  // overlap
  EXPECT_THROW(m.set_sparse_row(1, row({6, 0}, 4)), std::invalid_argument);        // past n
  EXPECT_THROW(m.set_sparse_row(1, row({1, 1}, 2)), std::invalid_argument);        // offset
}

}  // namespace
}  // namespace radlab
