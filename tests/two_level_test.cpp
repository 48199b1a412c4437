// Cohen et al. 1988's two levels (solvers/patches.h): patches shoot to elements, elements gather
// over patches, and both solve the one system K whose certified reference the metrics use; one
// element per patch is the one-level system bit for bit; a patch shot's books; patches from a
// coarser mesh; Gouraud display of a linear field; bad parameters.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "experiments/experiment_spec.h"
#include "formfactor/raycast.h"
#include "render/interpolation.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/patches.h"
#include "solvers/reference.h"
#include "solvers/registry.h"
#include "solvers/shooting_core.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

struct TwoLevelSetup {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix F;  // the symmetrised element matrix
  Patches patches;
  RowMatrix P;
  FormFactorMatrix K;
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
  s->K = two_level_matrix(s->F, s->patches);
  s->one_level = std::make_unique<System>(s->scene, s->mesh, s->F);
  s->two_level = std::make_unique<System>(s->scene, s->mesh, s->K, s->patches, s->P);
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

TEST(TwoLevel, OneElementPerPatchIsTheOneLevelSystemBitForBit) {
  // Every weight A_e/A_p is exactly 1, so P = F and K = F bit for bit, and every solver's
  // two-level path (patch priorities by scan, patch shots) must reproduce the one-level run:
  // solution, display, unshot and counters, step after step.
  auto s = setup("cornell", 3, Precision::kFloat, true);
  const size_t n = s->mesh.size();
  ASSERT_TRUE(s->two_level->two_level());
  ASSERT_EQ(s->patches.size(), n);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      ASSERT_EQ(s->K.at(i, j), s->F.at(i, j)) << i << "," << j;
      ASSERT_EQ(s->P.at(i, j), s->F.at(i, j)) << i << "," << j;
    }
  for (const SolverCase& c : kShootingAndGathering) {
    SCOPED_TRACE(c.name + " " + (c.params.empty() ? "" : c.params[0]));
    auto a = make(c.name, c.params), b = make(c.name, c.params);
    s->one_level->reset_counters();
    s->two_level->reset_counters();
    a->init(*s->one_level);
    b->init(*s->two_level);
    for (size_t step = 0; step < 2 * n; ++step) {
      const bool fa = a->step().finished, fb = b->step().finished;
      ASSERT_EQ(fa, fb) << "step " << step;
      ASSERT_TRUE(same_bits(a->solution(), b->solution())) << "step " << step;
      if (fa) break;
    }
    EXPECT_TRUE(same_bits(a->display(), b->display()));
    if (a->unshot()) {
      EXPECT_TRUE(same_bits(*a->unshot(), *b->unshot()));
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
}

TEST(TwoLevel, InterleavedRefusesPatchShooters) {
  auto s = setup("cube", 2, Precision::kFloat, false);
  auto solver = make("interleaved", {});
  testing::expect_error<UsageError>([&] { solver->init(*s->two_level); },
                                    {"interleaved", "without patches"});
}

// ---------------------------------------------------------------------------------------------
// Adaptive subdivision (solvers/two_level_adaptive.cpp).

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
  s->K = two_level_matrix(s->F, s->patches);
  s->two_level = std::make_unique<System>(scene, s->mesh, s->K, s->patches, s->P);
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

TEST(Adaptive, BadParametersAreUsageErrors) {
  using testing::expect_error;
  for (const std::string bad : {"threshold=0", "threshold=-1", "threshold=nan", "threshold=inf"})
    expect_error<UsageError>([&] { make("adaptive-shooting", {bad}); },
                             {"adaptive-shooting", "threshold"});
  expect_error<UsageError>([&] { make("adaptive-shooting", {"levels=-1"}); }, {"levels"});
}

}  // namespace
}  // namespace radlab
