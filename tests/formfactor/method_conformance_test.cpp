// Every registered form-factor method, built in or loaded from a plugin (RADLAB_PLUGIN_PATH, see
// docs/library.md), held to what it states about itself (formfactor/form_factor_method.h) and to
// what theory says of any form factor: rows of a closed scene sum to 1 within the stated row
// error; A_i F_ij = A_j F_ji within the stated reciprocity error; a row is the same bits alone,
// from the whole build and on any thread count; side files restore the stated error of a cached
// matrix; rows at a point are what the registry says; and parameters that are no valid value are
// refused naming the parameter.
//
// A method may refuse a scene it cannot compute (exact without visibility on a scene that can
// occlude): that must be an InputError (exit 3) naming why, and the test then checks nothing else
// of that scene.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "experiments/problem/problem.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/matrix/parallel_row.h"
#include "formfactor/matrix/symmetric_build.h"
#include "formfactor/registry.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/plugin_loader.h"
#include "tests/solver_support.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// The plugins RADLAB_PLUGIN_PATH names join the registry before the tests below are instantiated
// from it (static initialisation, before gtest's main), as in the solver conformance tests.
[[maybe_unused]] const bool plugins_loaded = [] {
  try {
    load_plugins_from_environment();
  } catch (const Error& e) {
    std::fprintf(stderr, "radlab: error: %s\n", e.what());
    std::exit(int(e.code()));
  }
  return true;
}();

struct Case {
  Scene scene;
  Mesh mesh;
};

// The six faces of the box [lo, hi], facing out (or in).
std::vector<std::vector<Vec3>> box(const Vec3& lo, const Vec3& hi, bool outward) {
  std::vector<std::vector<Vec3>> faces = {
      {{lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, lo.y, lo.z}},  // -z
      {{lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}},  // +z
      {{lo.x, lo.y, lo.z}, {lo.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {lo.x, hi.y, lo.z}},  // -x
      {{hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, lo.y, lo.z}},  // +x
      {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, lo.y, hi.z}, {lo.x, lo.y, hi.z}},  // -y
      {{lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z}},  // +y
  };
  if (!outward)
    for (auto& face : faces) std::reverse(face.begin(), face.end());
  return faces;
}

// "box-in-box": a closed room (inward faces) with a floating block (outward faces) in it, off
// centre: pairs of the room blocked by the block, and every element's hemisphere still closed by
// front faces (so its row sums to 1). Else a built-in scene.
std::unique_ptr<Case> make_case(const std::string& spec, int subdivisions) {
  auto c = std::make_unique<Case>();
  if (spec == "box-in-box") {
    auto faces = box(Vec3(0.0), Vec3(2.0, 1.5, 1.0), false);
    for (auto& face : box(Vec3(0.6, 0.4, 0.3), Vec3(1.1, 0.9, 0.6), true))
      faces.push_back(std::move(face));
    c->scene = testing::scene_of(faces);
  } else {
    c->scene = make_builtin_scene(spec);
  }
  validate_scene(c->scene);
  c->mesh = build_mesh(c->scene, {subdivisions, 0.0});
  return c;
}

// The method with its defaults on the case, or nullptr when it refuses the scene (an InputError
// that says why; anything else fails the test).
std::unique_ptr<FormFactorMethod> make_method(const std::string& name, const Case& c) {
  ParamBag none("form factors '" + name + "'");
  try {
    return make_form_factor_method(name, none, c.scene, c.mesh);
  } catch (const InputError& e) {
    EXPECT_GT(std::string(e.what()).size(), 20u) << "a refusal must say why";
    return nullptr;
  }
}

FormFactorMatrix whole_build(const FormFactorMethod& method, size_t n) {
  BuildReport report;
  return build_matrix(method, n, Precision::kDouble, Layout::kDense, report);
}

// Closed scenes, every element's hemisphere closed by front faces, whose rows sum to 1 exactly: a
// cube of equal elements, a box of three edge lengths (unequal areas, so reciprocity is not
// equality), and a box with a block floating in it (pairs blocked).
const char* const kClosed[] = {"cube", "furnace:lx=2,ly=1,lz=0.5", "box-in-box"};
// A furnished room: closed, but faces against other faces (a table leg on the floor) see the
// backs of others or nothing, so rows may sum to less than 1; never to more than 1 + the stated
// error (planar polygons cover each direction of a hemisphere at most once).
const char* const kFurnished = "room";
int subdivisions_of(const std::string& spec) {
  return spec == "room" ? 1 : 2;
}

class EveryMethod : public ::testing::TestWithParam<std::string> {};

// Row i of `f` against its stated limit: |sum - 1| <= limit where the scene is closed, sum <=
// 1 + limit anywhere.
void expect_row_sums(const FormFactorMethod& method, const FormFactorMatrix& f, size_t n,
                     const std::string& spec, bool closed) {
  std::string basis;
  const double stated = method.stated_row_sum_error(&basis);
  ASSERT_TRUE(std::isfinite(stated) && stated > 0.0) << method.name() << ": " << basis;
  for (size_t i = 0; i < n; ++i) {
    double sum = 0.0;
    for (size_t j = 0; j < n; ++j) sum += f.at(i, j);
    // A method stating row allowances holds each row to its own (the common part plus the
    // row's allowance).
    const double allowed = method.states_row_allowances()
                               ? method.row_sum_error_common() + method.row_sum_allowance(i)
                               : stated;
    EXPECT_LE(closed ? std::abs(sum - 1.0) : sum - 1.0, allowed)
        << method.name() << " on " << spec << ", row " << i << " (" << basis << ")";
  }
}

TEST_P(EveryMethod, RowsOfAClosedSceneSumToOneWithinTheStatedError) {
  for (const char* spec : kClosed) {
    const auto c = make_case(spec, subdivisions_of(spec));
    const auto method = make_method(GetParam(), *c);
    if (!method) continue;
    expect_row_sums(*method, whole_build(*method, c->mesh.size()), c->mesh.size(), spec, true);
  }
}

TEST_P(EveryMethod, RowsOfAFurnishedRoomSumToAtMostOnePlusTheStatedError) {
  const auto c = make_case(kFurnished, subdivisions_of(kFurnished));
  const auto method = make_method(GetParam(), *c);
  if (!method) return;
  expect_row_sums(*method, whole_build(*method, c->mesh.size()), c->mesh.size(), kFurnished, false);
}

TEST_P(EveryMethod, ReciprocalWithinTheStatedError) {
  bool stated_somewhere = false;
  for (const char* spec : kClosed) {
    const auto c = make_case(spec, subdivisions_of(spec));
    const auto method = make_method(GetParam(), *c);
    if (!method) continue;
    const FormFactorMatrix f = whole_build(*method, c->mesh.size());
    const std::optional<double> stated = method->stated_reciprocity_error();
    if (!stated) continue;
    stated_somewhere = true;
    const auto& area = c->mesh.area;
    for (size_t i = 0; i < c->mesh.size(); ++i)
      for (size_t j = i + 1; j < c->mesh.size(); ++j) {
        const double a = area[i] * f.at(i, j), b = area[j] * f.at(j, i);
        EXPECT_LE(std::abs(a - b), *stated * (a + b))
            << GetParam() << " on " << spec << ", pair " << i << ", " << j;
      }
  }
  if (!stated_somewhere)
    GTEST_SKIP() << GetParam() << " states no reciprocity error (a row is one point's view)";
}

TEST_P(EveryMethod, RowIsTheSameBitsAloneInTheWholeBuildAndOnAnyThreadCount) {
  // The room: blocked pairs, visibility rays where the method casts them.
  for (const char* spec : {"furnace:lx=2,ly=1,lz=0.5", "box-in-box", "room"}) {
    const auto c = make_case(spec, subdivisions_of(spec));
    const size_t n = c->mesh.size();
    std::optional<FormFactorMatrix> one_thread;
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      const auto method = make_method(GetParam(), *c);
      if (!method) continue;
      one_thread = whole_build(*method, n);
    }
    const auto method = make_method(GetParam(), *c);
    ASSERT_TRUE(method);
    const FormFactorMatrix all = whole_build(*method, n);
    std::optional<FormFactorMatrix> pairs_once;
    if (method->integrates_pairs_once()) {
      BuildReport report;
      pairs_once =
          build_matrix_symmetric(*method, c->mesh, Precision::kDouble, Layout::kDense, report);
    }
    // Rows alone, each from a fresh method (no state left by other rows), and split over threads.
    const auto fresh = make_method(GetParam(), *c);
    std::vector<double> alone(n), split(n);
    for (size_t i = 0; i < n; i += std::max<size_t>(1, n / 23)) {
      RowCost cost;
      fresh->row(i, alone, cost);
      row_in_parallel(*fresh, i, split, cost);
      for (size_t j = 0; j < n; ++j) {
        ASSERT_EQ(alone[j], all.at(i, j)) << GetParam() << " on " << spec << " F_" << i << "," << j;
        ASSERT_EQ(split[j], alone[j]) << GetParam() << " on " << spec << " F_" << i << "," << j;
        ASSERT_EQ(one_thread->at(i, j), alone[j]) << GetParam() << " on " << spec;
        if (pairs_once) {
          ASSERT_EQ(pairs_once->at(i, j), alone[j]) << GetParam() << " on " << spec;
        }
      }
    }
  }
}

TEST_P(EveryMethod, SideFilesRestoreTheStatedErrorOfACachedMatrix) {
  const auto c = make_case("furnace:lx=2,ly=1,lz=0.5", 2);
  const auto built = make_method(GetParam(), *c);
  ASSERT_TRUE(built);
  const FormFactorMatrix matrix = whole_build(*built, c->mesh.size());
  // Side files are bound to their matrix file's header and key (matrix_cache.h): a real cached
  // matrix, as the problem stage stores it.
  testing::TempDir folder;
  const MatrixCache cache(folder.path());
  const MatrixCacheKey key =
      matrix_cache_key(c->mesh, GetParam(), built->parameters(), Precision::kDouble);
  ASSERT_TRUE(cache.store(key, matrix, BuildReport{}));
  const std::string matrix_file = cache.path(key).string();
  built->save_side_files(matrix_file);
  const auto loaded = make_method(GetParam(), *c);
  ASSERT_TRUE(loaded->load_side_files(matrix_file, c->mesh.size())) << GetParam();
  EXPECT_EQ(loaded->stated_row_sum_error(), built->stated_row_sum_error()) << GetParam();
  // The emitters' sampling, for the methods that state it (hemicube), is restored as well.
  for (size_t i = 0; i < c->mesh.size(); ++i) {
    const auto was = built->row_emitter_sampling(i), is = loaded->row_emitter_sampling(i);
    ASSERT_EQ(was.has_value(), is.has_value()) << GetParam();
    if (was) {
      EXPECT_EQ(was->error, is->error) << GetParam() << " row " << i;
    }
  }
}

// Every side file beside a cached matrix (raycast's .sigma, the hemicube's .emitters, exact's
// .excess) is a checked matrix side file (matrix_cache.h): it reads back whole, and one flipped
// bit in its payload makes it unreadable, so the method treats it exactly as a missing file.
TEST_P(EveryMethod, SideFilesWithAFlippedBitAreTreatedAsMissing) {
  const auto c = make_case("furnace:lx=2,ly=1,lz=0.5", 2);
  const auto built = make_method(GetParam(), *c);
  ASSERT_TRUE(built);
  testing::TempDir folder;
  const MatrixCache cache(folder.path());
  const MatrixCacheKey key =
      matrix_cache_key(c->mesh, GetParam(), built->parameters(), Precision::kDouble);
  ASSERT_TRUE(cache.store(key, whole_build(*built, c->mesh.size()), BuildReport{}));
  const std::string matrix_file = cache.path(key).string();
  built->save_side_files(matrix_file);
  const size_t n = c->mesh.size();
  std::vector<std::string> side_files;
  for (const auto& entry : std::filesystem::directory_iterator(folder.path())) {
    const std::string path = entry.path().string();
    if (path.size() > matrix_file.size() && path.compare(0, matrix_file.size(), matrix_file) == 0)
      side_files.push_back(path);
  }
  // exact always keeps its rows' excesses (exact.h: records_row_excess): .excess is checked too.
  if (GetParam() == "exact") {
    EXPECT_EQ(side_files.size(), 1u);
  }
  for (const std::string& path : side_files) {
    const std::string suffix = path.substr(matrix_file.size());
    SCOPED_TRACE(GetParam() + " " + suffix);
    std::string bytes;
    {
      std::ifstream in(path, std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      bytes = text.str();
    }
    uint64_t payload = 0;  // the side file's size field, after its 8-byte magic
    ASSERT_GT(bytes.size(), 16u + 8u);
    std::memcpy(&payload, bytes.data() + 8, sizeof payload);
    ASSERT_TRUE(read_matrix_side_file(matrix_file, suffix, payload)) << "not a checked side file";
    const bool loads_intact = make_method(GetParam(), *c)->load_side_files(matrix_file, n);
    // A bit in the middle of the payload (which ends 8 checksum bytes before the file does).
    bytes[bytes.size() - 8 - payload / 2] ^= char(0x10);
    {
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out.write(bytes.data(), std::streamsize(bytes.size()));
    }
    EXPECT_FALSE(read_matrix_side_file(matrix_file, suffix, payload));
    const bool loads_flipped = make_method(GetParam(), *c)->load_side_files(matrix_file, n);
    std::filesystem::remove(path);
    const bool loads_missing = make_method(GetParam(), *c)->load_side_files(matrix_file, n);
    EXPECT_TRUE(loads_intact);
    EXPECT_EQ(loads_flipped, loads_missing);
  }
}

TEST_P(EveryMethod, RowsAtAPointAreWhatTheRegistrySays) {
  const auto c = make_case("cube", 2);
  const auto method = make_method(GetParam(), *c);
  ASSERT_TRUE(method);
  const bool registered = form_factor_method_info(GetParam()).rows_at_points;
  const size_t n = c->mesh.size();
  std::vector<double> at_point(n, -1.0), row(n);
  RowCost cost;
  const size_t i = n / 3;
  ASSERT_EQ(method->row_at_point(c->mesh.centroid[i], i, at_point, cost), registered);
  if (!registered) return;
  // At an element's centroid, in its plane and frame, the row is the element's own.
  method->row(i, row, cost);
  for (size_t j = 0; j < n; ++j) EXPECT_EQ(at_point[j], row[j]) << GetParam() << " F_" << i << j;
}

TEST_P(EveryMethod, BadParametersAreRefusedNamingTheParameter) {
  const auto c = make_case("cube", 1);
  const FormFactorMethodInfo& info = form_factor_method_info(GetParam());
  for (const ParameterInfo& p : info.parameters) {
    ParamBag bag = ParamBag::from_assignments({p.name + "=not-a-value"}, "form factors");
    try {
      make_form_factor_method(GetParam(), bag, c->scene, c->mesh);
      ADD_FAILURE() << GetParam() << " accepted " << p.name << "=not-a-value";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(p.name), std::string::npos) << e.what();
    }
  }
  ParamBag unknown = ParamBag::from_assignments({"no_such_key=1"}, "form factors");
  try {
    make_form_factor_method(GetParam(), unknown, c->scene, c->mesh);
    ADD_FAILURE() << GetParam() << " accepted no_such_key";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_key"), std::string::npos) << e.what();
  }
}

std::vector<std::string> registered_methods() {
  std::vector<std::string> names;
  for (const FormFactorMethodInfo& info : form_factor_methods()) names.push_back(info.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryMethod, ::testing::ValuesIn(registered_methods()),
                         testing::test_name);

// ---------------------------------------------------------------------------------------------
// The registry itself.

TEST(MethodRegistry, DefaultsAreTheOptionsStructsAndEveryKeyIsListed) {
  for (const FormFactorMethodInfo& info : form_factor_methods()) {
    const auto read = read_parameter_defaults(info);
    ASSERT_EQ(read.size(), info.parameters.size()) << info.name;
    for (const ParameterInfo& p : info.parameters) {
      ASSERT_TRUE(read.count(p.name)) << info.name << " " << p.name;
      EXPECT_EQ(read.at(p.name), p.default_value) << info.name << " " << p.name;
    }
  }
}

// The one default method name is a built-in method, and the CLI, the library's ProblemSpec and
// an experiment file all start from it.
TEST(MethodRegistry, TheDefaultMethodIsRegisteredAndUsedEverywhere) {
  EXPECT_NO_THROW(form_factor_method_info(kDefaultFormFactorMethod));
  EXPECT_EQ(ProblemSpec{}.ff_method, kDefaultFormFactorMethod);
}

TEST(MethodRegistry, RefusesListedButUnreadReadButUnlistedAndDuplicates) {
  const auto configure = [](ParamBag& bag) -> FormFactorMethodBuilder {
    bag.get_double("weight", 0.5);
    return {};
  };
  FormFactorMethodInfo listed_unread{
      "test-listed", "", {{"weight", "", ""}, {"other", "", ""}}, configure};
  testing::expect_error<InputError>([&] { register_form_factor_method(listed_unread); },
                                    {"test-listed", "'other' is listed"});
  FormFactorMethodInfo read_unlisted{"test-unlisted", "", {}, configure};
  testing::expect_error<InputError>([&] { register_form_factor_method(read_unlisted); },
                                    {"test-unlisted", "'weight' is read but not listed"});
  FormFactorMethodInfo taken{"raycast", "", {{"weight", "", ""}}, configure};
  testing::expect_error<InputError>([&] { register_form_factor_method(taken); },
                                    {"'raycast' is registered already"});
  testing::expect_error<UsageError>([&] { form_factor_method_info("no-such-method"); },
                                    {"no-such-method", "raycast"});
}

}  // namespace
}  // namespace radlab
