// Cohen et al. 1988's two levels (solvers/two_level/patches.h): patches shoot to elements,
// elements gather over patches, and both solve the one system K whose certified reference the
// metrics use; one element per patch is the one-level system bit for bit; a patch shot's books;
// patches from a coarser mesh; Gouraud display of a linear field; bad parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "core/limits.h"
#include "experiments/problem/problem.h"
#include "experiments/sweep/experiment_spec.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/raycast.h"
#include "metrics/error_metrics.h"
#include "render/interpolation.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/reference/reference.h"
#include "solvers/registry.h"
#include "solvers/two_level/patch_rows.h"
#include "solvers/two_level/patches.h"
#include "solvers/two_level/two_level_reference.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

struct TwoLevelSetup {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix F;  // the symmetrised element matrix
  Patches patches;
  RowMatrix P;                           // patch rows: the mean of F's rows (the `mean` rule)
  std::unique_ptr<TwoLevelRows> gather;  // K's rows from P
  FormFactorMatrix K;                    // K dense, for comparisons with the dense reference
  std::unique_ptr<System> one_level, two_level;
};

// Raycast form factors (4 rays), symmetrised as prepare_problem does for cached rows.
std::unique_ptr<TwoLevelSetup> setup(const std::string& spec, int subdiv, Precision precision,
                                     bool per_element) {
  auto s = std::make_unique<TwoLevelSetup>();
  s->scene = make_builtin_scene(spec);
  validate_scene(s->scene);
  s->mesh = build_mesh(s->scene, {subdiv, 0.0});
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(s->scene, s->mesh, options);
  BuildReport report;
  s->F = build_matrix(ff, s->mesh.size(), precision, report);
  symmetrise(s->F, s->mesh.area);
  s->patches = per_element ? element_patches(s->mesh) : polygon_patches(s->mesh);
  s->P = patch_rows(s->F, s->patches, s->F.precision());
  s->gather = std::make_unique<TwoLevelRows>(s->mesh, s->patches, s->P);
  s->K = dense_two_level_matrix(s->mesh, s->patches, s->P, s->F.precision());
  s->one_level = std::make_unique<System>(s->scene, s->mesh, s->F);
  s->two_level = std::make_unique<System>(s->scene, s->mesh, *s->gather, s->patches, s->P);
  return s;
}

std::unique_ptr<Solver> make(const std::string& name, const std::vector<std::string>& params) {
  ParamBag bag = ParamBag::from_assignments(params, "solver '" + name + "'");
  return make_solver(name, bag);
}

bool same_bits(const Radiosity& a, const Radiosity& b) {
  return a.channels() == b.channels() && a.size() == b.size() &&
         std::memcmp(a.raw().data(), b.raw().data(), a.raw().size_bytes()) == 0;
}

double max_relative_error(const Radiosity& B, const Radiosity& ref) {
  double worst = 0.0;
  for (int c = 0; c < ref.channels(); ++c)
    for (size_t i = 0; i < ref.size(); ++i)
      worst = std::max(worst, std::abs(B.at(c, i) - ref.at(c, i)) / std::abs(ref.at(c, i)));
  return worst;
}

struct SolverCase {
  std::string name;
  std::vector<std::string> params;
};
const std::vector<SolverCase> kShootingAndGathering = {
    {"jacobi", {}},
    {"gauss-seidel", {}},
    {"shooting", {}},
    {"sorted-shooting", {}},
    {"sorted-shooting", {"ambient=true"}},
    {"overshooting", {"variant=regather"}},
    {"overshooting", {"variant=ambient"}},
    {"overshooting", {"variant=regather", "clamp=true"}},
};

TEST(TwoLevel, OneElementPerPatchIsTheOneLevelSystem) {
  // Every weight A_e/A_p is exactly 1, so the patch rows are F's rows bit for bit, and every
  // shooting solver's two-level path (patch priorities by scan, patch shots through P) must
  // reproduce the one-level run: solution, display, unshot and counters, step after step.
  // The gathering rows are K_ej = P_je A_j / A_e: the system one-level shooting solves, F by
  // reciprocity; symmetrised F holds A_e F_ej = A_j F_je up to the float rounding of its two
  // stored halves, so K_ej = F_ej within 3 float ulps (two roundings of F, one of the double
  // product), and gathering on K follows gathering on F to that relative error times
  // ||(I-J)^-1|| (<= 5 at rho <= 0.8): 1e-5 is ten times that.
  auto s = setup("cornell", 3, Precision::kFloat, true);
  const size_t n = s->mesh.size();
  ASSERT_TRUE(s->two_level->two_level());
  ASSERT_EQ(s->patches.size(), n);
  const double ulp = std::ldexp(1.0, -24);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      ASSERT_EQ(s->P.at(i, j), s->F.at(i, j)) << i << "," << j;
      ASSERT_NEAR(s->K.at(i, j), s->F.at(i, j), 3 * ulp * s->F.at(i, j)) << i << "," << j;
    }
  for (const SolverCase& c : kShootingAndGathering) {
    SCOPED_TRACE(c.name + " " + (c.params.empty() ? "" : c.params[0]));
    auto a = make(c.name, c.params), b = make(c.name, c.params);
    s->one_level->reset_counters();
    s->two_level->reset_counters();
    a->init(*s->one_level);
    b->init(*s->two_level);
    const bool shoots = a->unshot() != nullptr && c.name != "jacobi" && c.name != "gauss-seidel";
    for (size_t step = 0; step < 2 * n; ++step) {
      const bool fa = a->step().finished, fb = b->step().finished;
      ASSERT_EQ(fa, fb) << "step " << step;
      if (shoots) {
        ASSERT_TRUE(same_bits(a->solution(), b->solution())) << "step " << step;
      }
      if (fa) break;
    }
    if (shoots) {
      EXPECT_TRUE(same_bits(a->display(), b->display()));
      EXPECT_TRUE(same_bits(*a->unshot(), *b->unshot()));
    } else {
      EXPECT_LT(max_relative_error(b->solution(), a->solution()), 1e-5);
    }
    EXPECT_EQ(s->one_level->rows_used(), s->two_level->rows_used());
    EXPECT_EQ(s->one_level->pair_evaluations(), s->two_level->pair_evaluations());
  }
}

TEST(TwoLevel, PatchShootingAndElementGatheringReachTheSameCertifiedReference) {
  // Double precision: the symmetrised matrix is then reciprocal to double rounding, so the patch
  // shot (P's row, transposed by reciprocity) and the element gather (K's row) are the same
  // system to ~1e-15, and every method must reach K's certified reference to far better than the
  // 1e-9 asked (the reference itself is certified to 1e-12 of max B).
  auto s = setup("cornell", 4, Precision::kDouble, false);
  const size_t n = s->mesh.size();
  ASSERT_LT(s->patches.size(), n / 4);  // polygons, each split 4 x 4 (triangles 16)
  const Reference ref = compute_reference(*s->two_level, s->K);
  ASSERT_EQ(ref.kind, "certified");
  // Not the one-level system: patches shooting their mean radiosity differ from elements
  // shooting their own by the discretisation (here ~1e-2), far above the tolerance below.
  const Reference one = compute_reference(*s->one_level, s->F);
  EXPECT_GT(max_relative_error(one.B, ref.B), 1e-4);
  for (const SolverCase& c : kShootingAndGathering) {
    SCOPED_TRACE(c.name + " " + (c.params.empty() ? "" : c.params[0]));
    auto solver = make(c.name, c.params);
    solver->init(*s->two_level);
    // 60 sweeps' worth of rows (rho <= 0.8 in the Cornell box: 0.8^60 ~ 1e-6 per sweep-bound for
    // Jacobi, far less for the others; patches need far fewer rows than elements).
    for (size_t step = 0; step < 200 * n; ++step)
      if (solver->step().finished) break;
    EXPECT_LT(max_relative_error(solver->solution(), ref.B), 1e-9);
  }
}

TEST(TwoLevel, APatchShotEmptiesThePatchAndDeliversItsPowerThroughItsRow) {
  auto s = setup("cornell", 4, Precision::kDouble, false);
  ShootingCore core;
  core.init(*s->two_level);
  const kernels::Argmax best = core.max_priority();
  const size_t p = best.index;
  const int C = core.channels();
  // The emitter patch (the only one with unshot energy), shot whole.
  ASSERT_GT(s->patches.members(p).size(), 1u);
  const Radiosity before = core.unshot();
  double s_p[3] = {0, 0, 0};
  for (int c = 0; c < C; ++c) s_p[c] = core.shooter_unshot(c, p);
  s->two_level->with_shooter_row(p, [&](const auto* row) { core.shoot(row, p, s_p, false); });
  for (int c = 0; c < C; ++c) {
    for (uint32_t e : s->patches.members(p)) EXPECT_EQ(core.unshot().at(c, e), 0.0);
    // Power: x gained A_p s_p exactly what the patch held; every receiver got rho_e P_pe A_p s_p
    // (power A_e dB_e), so the unshot power changed by A_p s_p (sum_e rho_e P_pe - 1).
    double gained = 0.0, delivered = 0.0, held = 0.0;
    for (size_t e = 0; e < s->mesh.size(); ++e) {
      gained += s->mesh.area[e] * core.shot().at(c, e);
      delivered += s->mesh.area[e] * (core.unshot().at(c, e) - before.at(c, e));
      held += s->two_level->reflectance().at(c, e) * s->P.at(p, e);
    }
    const double power = s->patches.area(p) * s_p[c];
    EXPECT_NEAR(gained, power, 1e-12 * power);
    EXPECT_NEAR(delivered, power * (held - 1.0), 1e-12 * power);
  }
}

TEST(TwoLevel, CoarseMeshPatchesGroupTheElementsTheyHold) {
  // A 2 m x 2 m floor meshed 8 x 8 (0.25 m elements); patches of 1 m: four patches of 16.
  Scene scene = testing::scene_of({{{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}}});
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {8, 0.0});
  const Patches patches = coarse_mesh_patches(scene, mesh, 1.0);
  ASSERT_EQ(patches.size(), 4u);
  for (size_t p = 0; p < 4; ++p) {
    EXPECT_EQ(patches.members(p).size(), 16u);
    EXPECT_NEAR(patches.area(p), 1.0, 1e-12);
    for (uint32_t e : patches.members(p)) {
      // Each element lies in one 1 m cell: its centroid's cell is the same for all members.
      const Vec3 c0 = mesh.centroid[patches.members(p)[0]], c = mesh.centroid[e];
      EXPECT_EQ(std::floor(c.x), std::floor(c0.x));
      EXPECT_EQ(std::floor(c.y), std::floor(c0.y));
    }
  }
}

TEST(TwoLevel, GouraudDisplayReproducesALinearFieldInsideTheMesh) {
  // Element values of a linear field (its value at each centroid) -> area-weighted vertex values
  // -> interpolation inside each element: exact in every element whose corners are all interior
  // vertices of the uniform grid (there the surrounding elements are point-symmetric).
  Scene scene = testing::scene_of({{{0, 0, 0}, {3, 0, 0}, {3, 2, 0}, {0, 2, 0}}});
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {6, 0.0});
  auto field = [](const Vec3& p) { return 2.0 * p.x - 0.5 * p.y + 4.0; };
  std::vector<glm::dvec3> values(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) values[e] = glm::dvec3(field(mesh.centroid[e]));
  const std::vector<glm::dvec3> vertex = smooth_vertex_values(mesh, values);
  std::vector<int> uses(mesh.vertices.size(), 0);
  for (size_t e = 0; e < mesh.size(); ++e)
    for (uint32_t v : mesh.element_vertices(e)) ++uses[v];
  int checked = 0;
  for (size_t e = 0; e < mesh.size(); ++e) {
    bool interior = true;
    for (uint32_t v : mesh.element_vertices(e)) interior = interior && uses[v] == 4;
    if (!interior) continue;
    ++checked;
    std::vector<Vec3> corners;
    mesh.corners(e, corners);
    for (double a : {0.1, 0.5, 0.8})
      for (double b : {0.2, 0.7}) {
        const Vec3 p = corners[0] + a * (corners[1] - corners[0]) + b * (corners[3] - corners[0]);
        EXPECT_NEAR(interpolate_on_element(mesh, vertex, e, p).x, field(p), 1e-12);
      }
  }
  EXPECT_EQ(checked, 16);  // the 4 x 4 elements away from the border of a 6 x 6 grid
}

TEST(TwoLevel, BadPatchParametersAreUsageErrors) {
  using testing::expect_error;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (double size : {0.0, -1.0, nan, std::numeric_limits<double>::infinity()})
    expect_error<UsageError>(
        [&] {
          PatchOptions o;
          o.from = "size";
          o.size = size;
          o.validate();
        },
        {"patches: size must be a finite length > 0"});
  expect_error<UsageError>(
      [] {
        PatchOptions o;
        o.from = "walls";
        o.validate();
      },
      {"from must be elements, polygons or size", "walls"});
  expect_error<UsageError>(
      [] {
        PatchOptions o;
        o.from = "polygons";
        o.size = 1.0;
        o.validate();
      },
      {"size is used only with from = \"size\""});
  expect_error<UsageError>(
      [] {
        PatchOptions o;
        o.from = "polygons";
        o.rows = "corner";
        o.validate();
      },
      {"rows must be auto, centre or mean", "corner"});
  expect_error<UsageError>(
      [] {
        PatchOptions o;
        o.rows = "centre";  // one level: no patch rows to make
        o.validate();
      },
      {"rows is used only with two levels"});
  // Larger than the scene: a 1 m square (diagonal 1.41 m) with 2 m patches.
  Scene scene = testing::scene_of({{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}});
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {4, 0.0});
  expect_error<UsageError>([&] { coarse_mesh_patches(scene, mesh, 2.0); },
                           {"exceeds the scene's extent", "use from = \"polygons\""});
  // In an experiment file: file and line named.
  testing::TempDir dir;
  const std::string file =
      dir.write("bad.toml",
                "scenes = [\"builtin:cube\"]\nsolvers = [\"shooting\"]\n[patches]\nfrom = "
                "\"size\"\nsize = -0.5\n");
  expect_error<InputError>([&] { read_experiment(file); }, {"bad.toml:3", "size must be"});
  const std::string rows =
      dir.write("rows.toml",
                "scenes = [\"builtin:cube\"]\nsolvers = [\"shooting\"]\n[patches]\nfrom = "
                "\"polygons\"\nrows = \"edges\"\n");
  expect_error<InputError>([&] { read_experiment(rows); }, {"rows.toml:3", "rows must be"});
}

TEST(TwoLevel, ConjugateGradientRefusesTheTwoLevelSystem) {
  // K is not reciprocal, and CG's symmetrise=true would converge to another system than the
  // certified one: both refused, naming why.
  auto s = setup("cube", 2, Precision::kFloat, false);
  for (const std::vector<std::string>& params :
       {std::vector<std::string>{}, std::vector<std::string>{"symmetrise=true"}}) {
    auto solver = make("conjugate-gradient", params);
    testing::expect_error<UsageError>([&] { solver->init(*s->two_level); },
                                      {"conjugate-gradient", "two-level", "not"});
  }
}

TEST(TwoLevel, InterleavedRefusesPatchShooters) {
  auto s = setup("cube", 2, Precision::kFloat, false);
  auto solver = make("interleaved", {});
  testing::expect_error<UsageError>([&] { solver->init(*s->two_level); },
                                    {"interleaved", "without patches"});
}

// ---------------------------------------------------------------------------------------------
// Patch rows from the method (solvers/two_level/patch_rows.h) and the rank-P reference
// (solvers/two_level/two_level_reference.h).

TEST(PatchRows, TheCentreHemicubeOfAOneElementPatchIsItsElementRow) {
  // One element per patch: the patch's centre and frame are the element's, so the patch
  // hemicube must be the element's hemicube row bit for bit (the one-level system's rows).
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {2, 0.0});
  HemicubeOptions options;
  options.resolution = 48;
  HemicubeFormFactors hemicube(scene, mesh, options);
  const Patches patches = element_patches(mesh);
  PatchRowReport report;
  const RowMatrix P = compute_patch_rows(hemicube, mesh, patches, PatchRowRule::kCentre,
                                         Precision::kDouble, report);
  EXPECT_EQ(report.method_rows, mesh.size());
  std::vector<double> row(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    RowCost cost;
    hemicube.row(e, row, cost);
    for (size_t j = 0; j < mesh.size(); ++j) ASSERT_EQ(P.at(e, j), row[j]) << e << "," << j;
  }
}

TEST(PatchRows, TheCentreRuleSeesFromThePatchCentreAndTheMeanRuleFromAllOfIt) {
  // Two parallel unit squares 1 m apart, each one patch of 4 x 4 elements. The centre rule's
  // row sums to the point-to-square form factor at the source's centre (Lambert, 0.2395); the
  // mean rule's to the square-to-square factor (0.1998; Howell's catalogue C-11). The top face
  // of a 150-pixel hemicube holds the square's image with its edges on pixel centres (counted
  // exactly by the half-open rule), so only the midpoint rule's O(h^2) error remains,
  // h = 2/150: 1e-3 is several times it and far below the 0.04 between the two rules.
  Scene scene = testing::scene_of(
      {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}}});
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {4, 0.0});
  HemicubeFormFactors hemicube(scene, mesh, HemicubeOptions{});
  const Patches patches = polygon_patches(mesh);
  ASSERT_EQ(patches.size(), 2u);
  PatchRowReport report;
  const RowMatrix centre = compute_patch_rows(hemicube, mesh, patches, PatchRowRule::kCentre,
                                              Precision::kDouble, report);
  EXPECT_EQ(report.method_rows, 2u);  // one hemicube per patch
  const RowMatrix mean =
      compute_patch_rows(hemicube, mesh, patches, PatchRowRule::kMean, Precision::kDouble, report);
  EXPECT_EQ(report.method_rows, 32u);  // every element row
  auto sum = [&](const RowMatrix& rows, size_t p) {
    double total = 0.0;
    for (size_t e = 0; e < mesh.size(); ++e) total += rows.at(p, e);
    return total;
  };
  std::vector<Vec3> scratch;
  const std::vector<Vec3> receiver = scene.polygons[1].vertices;
  const double point = point_to_polygon_form_factor(Vec3(0.5, 0.5, 0), Vec3(0, 0, 1), receiver,
                                                    Vec3(0, 0, -1), scratch);
  EXPECT_NEAR(point, 0.2395, 1e-4);
  EXPECT_NEAR(sum(centre, 0), point, 1e-3);
  EXPECT_NEAR(sum(mean, 0), 0.1998, 2e-3);  // the mean of 16 hemicubes, each to 1e-3
  // Nothing of the source's own patch is seen.
  for (uint32_t e : patches.members(0)) EXPECT_EQ(centre.at(0, e), 0.0);
  // Centre needs a hemicube.
  RaycastFormFactors raycast(scene, mesh, RaycastOptions{});
  testing::expect_error<UsageError>(
      [&] {
        compute_patch_rows(raycast, mesh, patches, PatchRowRule::kCentre, Precision::kDouble,
                           report);
      },
      {"needs --ff hemicube", "mean"});
}

// The rank-P reference against the dense LU reference of the same K (built dense here only for
// the comparison): the two certified solutions must agree within the sum of their bounds, on the
// Cornell box (RGB, hemicube centre rows: element-to-patch sums above 1) and on a closed cube at
// rho = 0.99 (||(I-J)^-1|| ~ 100: a wrong rounding bound or reduction shows).
void expect_references_agree(const std::string& spec, int subdiv) {
  SCOPED_TRACE(spec);
  Scene scene = make_builtin_scene(spec);
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {subdiv, 0.0});
  HemicubeOptions options;
  options.resolution = 64;
  HemicubeFormFactors hemicube(scene, mesh, options);
  const Patches patches = polygon_patches(mesh);
  PatchRowReport report;
  const RowMatrix P = compute_patch_rows(hemicube, mesh, patches, PatchRowRule::kCentre,
                                         Precision::kDouble, report);
  TwoLevelRows gather(mesh, patches, P);
  System system(scene, mesh, gather, patches, P);
  const Reference low = compute_two_level_reference(system, patches, P);
  const FormFactorMatrix K = dense_two_level_matrix(mesh, patches, P, Precision::kDouble);
  const Reference dense = compute_reference(system, K);
  ASSERT_EQ(low.kind, "certified");
  EXPECT_LT(low.bound_relative, 1e-10);
  for (int c = 0; c < system.channels(); ++c)
    for (size_t e = 0; e < mesh.size(); ++e)
      ASSERT_NEAR(low.B.at(c, e), dense.B.at(c, e), low.bound_inf + dense.bound_inf)
          << "channel " << c << " element " << e;
  // The residual from the patch rows equals the dense one to rounding (both bound their own).
  Radiosity perturbed = low.B;
  for (size_t e = 0; e < mesh.size(); ++e) perturbed.at(0, e) *= 1.001;
  const auto r_low = two_level_residual_inf(system, patches, P, perturbed);
  const auto r_dense = residual_inf(system, K, perturbed);
  EXPECT_NEAR(r_low[0], r_dense[0], 1e-9 * r_dense[0]);
  EXPECT_GT(r_low[0], 1e-4);
  // Power is conserved by the patch rows (<= 1 + the hemicube's midpoint excess) whatever the
  // element-to-patch sums.
  EXPECT_LT(report.max_row_sum, 1.001);
  std::printf("%s: q %.4f, element-to-patch max sum %.4f, spectral radius <= %.6f, %s\n",
              spec.c_str(), low.q, report.max_gather_sum, low.spectral_radius_upper,
              low.summary().c_str());
}

TEST(TwoLevelReference, AgreesWithTheDenseReferenceOfTheSameSystem) {
  expect_references_agree("cornell", 3);
  expect_references_agree("cube:rho=0.99", 4);
}

TEST(TwoLevelReference, PrepareProblemHoldsNoDenseMatrix) {
  // A memory limit below the n x n float matrix and above the P x n double patch rows: the
  // one-level problem is refused before allocating, the two-level one runs and certifies.
  ProblemSpec spec;
  spec.scene = "builtin:cornell";
  spec.mesh = {4, 0.0};
  spec.ff_method = "hemicube";
  spec.ff_set = {"resolution=48"};
  spec.use_cache = false;
  const double saved = limits().memory_gb;
  const size_t n = 20 * 16;  // Cornell's 20 polygons at --subdiv 4
  limits().memory_gb = 0.5 * double(n) * double(n) * 4.0 / 1e9;
  testing::expect_error<InputError>([&] { prepare_problem(spec); }, {"memory_gb"});
  spec.patches.from = "polygons";
  std::unique_ptr<Problem> problem;
  try {
    problem = prepare_problem(spec);
  } catch (...) {
    limits().memory_gb = saved;
    throw;
  }
  limits().memory_gb = saved;
  EXPECT_FALSE(problem->has_matrix());
  EXPECT_EQ(problem->patch_rows.rows(), problem->patches.size());
  EXPECT_EQ(problem->patch_row_report.method_rows, problem->patches.size());
  ASSERT_TRUE(problem->reference);
  EXPECT_EQ(problem->reference->kind, "certified");
  EXPECT_LT(problem->reference->bound_relative, 1e-10);
  // Sorted patch shooting reaches it.
  auto solver = make("sorted-shooting", {});
  solver->init(*problem->system);
  for (int step = 0; step < 20000; ++step)
    if (solver->step().finished) break;
  EXPECT_LT(max_relative_error(solver->solution(), problem->reference->B), 1e-5);
}

TEST(TwoLevel, AllMeansTheSolversThatRunOnTheProblem) {
  testing::TempDir dir;
  auto names = [](const ExperimentSpec& spec) {
    std::vector<std::string> out;
    for (const auto& s : spec.solvers) out.push_back(s.name);
    return out;
  };
  auto has = [](const std::vector<std::string>& v, const std::string& name) {
    return std::find(v.begin(), v.end(), name) != v.end();
  };
  const auto one = names(
      read_experiment(dir.write("one.toml", "scenes = [\"builtin:cube\"]\nsolvers = [\"all\"]\n")));
  EXPECT_FALSE(has(one, "adaptive-shooting"));
  EXPECT_TRUE(has(one, "conjugate-gradient"));
  EXPECT_TRUE(has(one, "sorted-shooting"));
  const auto two = names(read_experiment(dir.write(
      "two.toml",
      "scenes = [\"builtin:cube\"]\nsolvers = [\"all\"]\n[patches]\nfrom = \"polygons\"\n")));
  EXPECT_TRUE(has(two, "adaptive-shooting"));
  EXPECT_FALSE(has(two, "conjugate-gradient"));
  EXPECT_FALSE(has(two, "hierarchical"));
  EXPECT_TRUE(has(two, "gauss-seidel"));
}

// ---------------------------------------------------------------------------------------------
// Adaptive subdivision (solvers/two_level/two_level_adaptive.cpp).

// A 2 m x 1 m floor (reflectance 0.5) under a 20 m x 20 m emitter at 0.5 m, with a blind at
// 0.05 m over x in [1, 2.5]: the floor is lit almost uniformly for x < 1 (the emitter fills its
// sky) and dark beyond, with a sharp shadow edge along x = 1. 16 x 16 elements per polygon, so
// x = 1 is an element boundary.
std::unique_ptr<TwoLevelSetup> shadow_edge_setup() {
  auto s = std::make_unique<TwoLevelSetup>();
  Scene& scene = s->scene;
  scene.name = "shadow-edge";
  scene.materials = {{"grey", Rgb(0.5), Rgb(0.0)}, {"light", Rgb(0.0), Rgb(1.0)}};
  scene.polygons = {
      {{{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}}, 0, "floor"},
      {{{-9, -9.5, 0.5}, {-9, 10.5, 0.5}, {11, 10.5, 0.5}, {11, -9.5, 0.5}}, 1, "light"},
      {{{1, -0.5, 0.05}, {1, 1.5, 0.05}, {2.5, 1.5, 0.05}, {2.5, -0.5, 0.05}}, 0, "blind"},
  };
  validate_scene(scene);
  s->mesh = build_mesh(scene, {16, 0.0});
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(scene, s->mesh, options);
  BuildReport report;
  s->F = build_matrix(ff, s->mesh.size(), Precision::kDouble, report);
  symmetrise(s->F, s->mesh.area);
  s->patches = polygon_patches(s->mesh);
  s->P = patch_rows(s->F, s->patches, s->F.precision());
  s->gather = std::make_unique<TwoLevelRows>(s->mesh, s->patches, s->P);
  s->two_level = std::make_unique<System>(scene, s->mesh, *s->gather, s->patches, s->P);
  return s;
}

TEST(Adaptive, SplitsAlongTheShadowEdgeAndNowhereElseOnTheFloor) {
  auto s = shadow_edge_setup();
  // levels = 2: the floor starts as 4 x 4 blocks of 4 x 4 elements (0.5 m x 0.25 m).
  auto solver = make("adaptive-shooting", {"threshold=1", "levels=2"});
  solver->init(*s->two_level);
  EXPECT_EQ(solver->solver_elements(), 3u * 16u);
  solver->step();  // the light shoots; only the floor receives
  ASSERT_GT(solver->solver_elements(), 48u);
  // The lit floor is near uniform (checked, so the test's premise holds), the shadow dark.
  const Radiosity& B = solver->solution();
  const Mesh& mesh = s->mesh;
  double lit_lo = 1e300, lit_hi = 0.0;
  for (size_t e = 0; e < mesh.size(); ++e)
    if (mesh.polygon[e] == 0 && mesh.centroid[e].x < 0.5) {
      lit_lo = std::min(lit_lo, B.at(0, e));
      lit_hi = std::max(lit_hi, B.at(0, e));
    }
  ASSERT_GT(lit_lo, 0.4);
  // Which floor elements ended in a block of their own: recover blocks from equal values is not
  // possible, so count elements sharing each value within the floor's 4 x 4 starting blocks.
  // Instead: the solution is constant on every block, so an unsplit starting block shows one
  // value on its 16 elements. Far from the edge (x < 0.5 lit, x > 1.5 dark) blocks stay whole;
  // next to the edge every element is its own block (the values of the 4 elements of one row
  // beside x = 1 differ).
  auto value_at = [&](double x, double y) {
    for (size_t e = 0; e < mesh.size(); ++e)
      if (mesh.polygon[e] == 0 && std::abs(mesh.centroid[e].x - x) < 1e-9 &&
          std::abs(mesh.centroid[e].y - y) < 1e-9)
        return B.at(0, e);
    ADD_FAILURE() << "no floor element at " << x << "," << y;
    return 0.0;
  };
  const double h = 0.125, k = 0.0625;  // element size in x and y
  for (int row = 0; row < 16; ++row) {
    const double y = (row + 0.5) * k;
    // Uniformly lit and deep shadow: each starting block (4 elements across) one value.
    for (double x0 : {0.0, 1.5})
      for (int i = 1; i < 4; ++i)
        EXPECT_EQ(value_at(x0 + (i + 0.5) * h, y), value_at(x0 + 0.5 * h, y))
            << "split at x " << x0 + (i + 0.5) * h << " y " << y;
    // Along the edge: the elements on either side are separate (the lit one brighter).
    EXPECT_GT(value_at(1.0 - 0.5 * h, y), value_at(1.0 + 0.5 * h, y) + 0.1);
    EXPECT_NE(value_at(1.0 + 0.5 * h, y), value_at(1.0 + 1.5 * h, y));
    EXPECT_NE(value_at(1.0 - 0.5 * h, y), value_at(1.0 - 1.5 * h, y));
  }
}

TEST(Adaptive, SplitsConservePower) {
  // Every step: sum A B grows by exactly what the patch delivered through its (fine) row,
  // A_p dB_p sum_e rho_e P_pe, and sum A dB by that minus A_p dB_p, splits or not; the blocks'
  // deliveries sum to the fine delivery and a split re-deals a block's values among its children.
  auto s = shadow_edge_setup();
  auto solver = make("adaptive-shooting", {"threshold=0.2", "levels=1"});
  solver->init(*s->two_level);
  const Mesh& mesh = s->mesh;
  auto power = [&](const Radiosity& field) {
    double sum = 0.0;
    for (size_t e = 0; e < mesh.size(); ++e) sum += mesh.area[e] * field.at(0, e);
    return sum;
  };
  size_t splits = 0;
  for (int step = 0; step < 12; ++step) {
    const Radiosity* unshot = solver->unshot();
    ASSERT_NE(unshot, nullptr);
    const Radiosity dB = *unshot;
    // The patch the solver will shoot: the largest |sum_{e in p} A_e dB_e|.
    size_t p = 0;
    double best = -1.0, held = 0.0;
    for (size_t q = 0; q < s->patches.size(); ++q) {
      double v = 0.0;
      for (uint32_t e : s->patches.members(q)) v += mesh.area[e] * dB.at(0, e);
      if (std::abs(v) > best) {
        best = std::abs(v);
        held = v;
        p = q;
      }
    }
    double reach = 0.0;  // sum_e rho_e P_pe
    for (size_t e = 0; e < mesh.size(); ++e)
      reach += s->two_level->reflectance().at(0, e) * s->P.at(p, e);
    const double B0 = power(solver->solution()), U0 = power(dB);
    const size_t before = solver->solver_elements();
    solver->step();
    splits += solver->solver_elements() - before;
    const double scale = std::max(std::abs(B0), 1e-300);
    EXPECT_NEAR(power(solver->solution()) - B0, held * reach, 1e-12 * scale) << "step " << step;
    const Radiosity* after = solver->unshot();
    ASSERT_NE(after, nullptr);
    EXPECT_NEAR(power(*after) - U0, held * (reach - 1.0), 1e-12 * scale) << "step " << step;
  }
  EXPECT_GT(splits, 0u);
}

TEST(Adaptive, AtTheFinestLevelItReachesTheFineReference) {
  // levels deep enough that every block is one element from the start: sorted patch shooting on
  // the fine two-level system, which must reach its certified reference.
  auto s = setup("cornell", 4, Precision::kDouble, false);
  const Reference ref = compute_reference(*s->two_level, s->K);
  auto solver = make("adaptive-shooting", {"levels=4"});
  solver->init(*s->two_level);
  EXPECT_EQ(solver->solver_elements(), s->mesh.size());
  for (size_t step = 0; step < 100 * s->mesh.size(); ++step)
    if (solver->step().finished) break;
  EXPECT_LT(max_relative_error(solver->solution(), ref.B), 1e-9);
}

TEST(Adaptive, TheFinalSystemIsTheBlocksSystemOnTheEvaluationMesh) {
  // block_rows: identity blocks give the rows back; coarser blocks keep every patch row's sum
  // (the power a patch sends) and give a certified reference constant on every block, which
  // differs from the fine reference by the blocks' discretisation (>1e-3 here: Cornell's light
  // falls off across a 4 x 4 polygon), far above the two bounds.
  auto s = setup("cornell", 4, Precision::kDouble, false);
  const Mesh& mesh = s->mesh;
  const size_t n = mesh.size();
  std::vector<uint32_t> identity(n);
  for (size_t e = 0; e < n; ++e) identity[e] = uint32_t(e);
  const RowMatrix same = block_rows(s->P, mesh.area, identity);
  for (size_t p = 0; p < s->patches.size(); ++p)
    for (size_t e = 0; e < n; ++e) ASSERT_NEAR(same.at(p, e), s->P.at(p, e), 1e-15);
  // Blocks: each patch's elements in pairs by index (a block of one or two elements).
  std::vector<uint32_t> blocks(n);
  uint32_t count = 0;
  for (size_t p = 0; p < s->patches.size(); ++p) {
    const auto members = s->patches.members(p);
    for (size_t k = 0; k < members.size(); ++k) {
      if (k % 2 == 0) ++count;
      blocks[members[k]] = count - 1;
    }
  }
  const RowMatrix coarse = block_rows(s->P, mesh.area, blocks);
  for (size_t p = 0; p < s->patches.size(); ++p) {
    double fine_sum = 0.0, coarse_sum = 0.0;
    for (size_t e = 0; e < n; ++e) {
      fine_sum += s->P.at(p, e);
      coarse_sum += coarse.at(p, e);
    }
    EXPECT_NEAR(coarse_sum, fine_sum, 1e-14);
  }
  TwoLevelRows gather(mesh, s->patches, coarse);
  System system(s->scene, mesh, gather, s->patches, coarse);
  const Reference final_ref = compute_two_level_reference(system, s->patches, coarse);
  const Reference fine_ref = compute_two_level_reference(*s->two_level, s->patches, s->P);
  for (int c = 0; c < system.channels(); ++c)
    for (size_t e = 0; e < n; ++e)
      for (size_t f = e + 1; f < n && f < e + 20; ++f)
        if (blocks[f] == blocks[e]) {
          ASSERT_NEAR(final_ref.B.at(c, e), final_ref.B.at(c, f), 1e-12 * final_ref.B.at(c, e));
        }
  const double apart = compare(final_ref.B, fine_ref.B, mesh.area, kMeanOfChannels).rms_rel;
  EXPECT_GT(apart, 1e-3);
  EXPECT_LT(final_ref.bound_relative, 1e-10);
}

TEST(Adaptive, BadParametersAreUsageErrors) {
  using testing::expect_error;
  for (const std::string bad : {"threshold=0", "threshold=-1", "threshold=nan", "threshold=inf"})
    expect_error<UsageError>([&] { make("adaptive-shooting", {bad}); },
                             {"adaptive-shooting", "threshold"});
  expect_error<UsageError>([&] { make("adaptive-shooting", {"levels=-1"}); }, {"levels"});
}

}  // namespace
}  // namespace radlab
