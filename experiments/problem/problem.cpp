#include "experiments/problem/problem.h"

#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "core/limits.h"
#include "core/log.h"
#include "core/progress.h"
#include "experiments/problem/preparation_estimate.h"
#include "experiments/problem/reference_cache.h"
#include "experiments/problem/two_level_problem.h"
#include "formfactor/matrix/matrix_blocks.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/matrix/symmetric_build.h"
#include "formfactor/registry.h"

namespace radlab {
namespace {

// The row-sum check of every dense build (formfactor/matrix/diagnostics.h): rows above 1 + the
// method's stated error are reported with their worst entries and polygons. `used`: the matrix the
// solvers use (symmetrised); else the method's own.
void check_row_sums(Problem& problem, bool used) {
  RowSumCheck& check = used ? problem.used_row_sums : problem.row_sums;
  check = check_row_sums(problem.matrix, problem.scene(), problem.mesh, *problem.method);
  if (!check.ok())
    log::warning(std::string(used ? "form factors (symmetrised): " : "form factors: ") +
                 check.report(problem.scene(), problem.mesh));
}

// The reference solves the system it is given; a system no planar scene can have is refused
// here, before minutes of work, rather than blamed on the spectral radius afterwards: rows of the
// method's own matrix above 1 + its stated error, or a matrix that does not carry the emitters'
// light (gathered power far from what the emitters' rows send: raw hemicubes missing a tiny
// lamp). Symmetrised rows above the limit only warn (check_row_sums): symmetrising an aliased
// hemicube moves form factor between rows (docs/formfactors.md).
// With --ff-set unphysical=accept the first test only warns, and the certificate says so.
void refuse_unphysical(const Problem& problem, bool accept_row_sums, double ratio) {
  if (!problem.row_sums.ok()) {
    const std::string what = "the form factors are unphysical, " +
                             problem.row_sums.report(problem.scene(), problem.mesh) +
                             "\n(docs/scenes.md lists the causes and repairs)";
    if (!accept_row_sums)
      throw NumericalError("refusing to solve: " + what +
                           "; --ff-set unphysical=accept solves it anyway, labelled as such");
    log::warning("solving anyway (unphysical=accept): " + what);
  }
  char buffer[300];
  std::snprintf(buffer, sizeof buffer,
                "the matrix lets the elements gather %.3g times the power the emitters' rows send "
                "(1 when reciprocal; reciprocity defect relative %.3g)",
                ratio, problem.diagnostics.reciprocity_defect_relative);
  if (!(ratio > 0.5 && ratio < 2.0))
    throw NumericalError(std::string("refusing to solve: ") + buffer +
                         "; the emitters' light does not reach the system (an emitter too small "
                         "for the method's rows?); use a dense symmetrised matrix or raycast");
  if (std::abs(ratio - 1.0) > 0.1) log::warning(std::string("form factors: ") + buffer);
}

// How well the rows sample the emitters, for methods that state it (a hemicube's pixels on a
// small lamp): the reference is certified on the same rows, so a run scores itself exact however
// badly they miss the lamp; this is the only place that can say so. Above 1% of the direct power
// gathered, a warning (the figure is in run.json either way).
void check_emitter_sampling(Problem& problem) {
  problem.emitter_sampling = emitter_sampling_report(*problem.method, problem.mesh);
  const EmitterSamplingReport& report = problem.emitter_sampling;
  if (!report.stated) return;
  const std::string what = "form factors: " + report.text();
  if (report.relative > 0.01)
    log::warning(what +
                 "; the reference is of these rows and cannot see it (raise the "
                 "resolution, subdivide the emitter less, or use raycast)");
  else
    log::info(what);
}

// "stored sparse, 123.4 MB (45.6% of dense)": what a matrix holds in memory
// (formfactor/matrix/matrix.h).
void log_storage(const std::string& what, const FormFactorMatrix& m) {
  const double dense = double(m.size()) * double(m.size()) *
                       (m.precision() == Precision::kFloat ? sizeof(float) : sizeof(double));
  char buffer[200];
  std::snprintf(buffer, sizeof buffer, "%s: stored %s, %.1f MB (%.1f%% of dense)", what.c_str(),
                m.sparse() ? "sparse" : "dense", double(m.bytes()) / 1e6,
                dense > 0 ? 100.0 * double(m.bytes()) / dense : 0.0);
  log::info(buffer);
}

// What the stages hand on to each other besides the problem itself.
struct Preparation {
  Preparation(Problem& problem_in, const ProblemSpec& spec_in)
      : problem(problem_in), spec(spec_in) {}
  Problem& problem;
  const ProblemSpec& spec;
  // The generic form-factor options of --ff-set (any method), read by the method stage.
  bool symmetrise = false;
  bool accept_unphysical = false;
  Precision precision = Precision::kFloat;
  // The cache (when used) and the key of this problem's matrix in it.
  std::filesystem::path cache_dir;
  std::optional<MatrixCache> cache;
  MatrixCacheKey key;
  // Rows on the fly with the reference in the cache: the reference certified with the rows the
  // method computes, the row sums of that pass, and the System it was certified on.
  std::optional<StreamedCheck> streamed;
  std::unique_ptr<System> streamed_system;
  // Whether that pass was read from the reference cache's stored check (not recomputed).
  bool streamed_check_stored = false;
  // While the matrix is built and stored: the lock that makes concurrent processes build it once.
  std::unique_ptr<FileLock> building;

  size_t n() const { return problem.mesh.size(); }
};

// Stage 1, scene: loaded, validated, overlaps resolved (scene/scene_loader.h).
void scene_stage(Preparation& p) {
  p.problem.loaded = load_scene(p.spec.scene, true, p.spec.keep_overlaps);
  if (p.spec.require_emitter) require_emitter(p.problem.scene());
}

// Stage 2, mesh.
void mesh_stage(Preparation& p) {
  Problem& problem = p.problem;
  if (p.spec.mesh.subdivisions < 1) throw UsageError("--subdiv must be >= 1");
  if (p.spec.mesh.element_size < 0) throw UsageError("--element-size must be > 0");
  problem.mesh = build_mesh(problem.scene(), p.spec.mesh);
  log::info(problem.scene().name + ": " + std::to_string(problem.scene().polygons.size()) +
            " polygons, " + std::to_string(problem.mesh.size()) + " elements, " +
            (problem.scene().is_grey() ? "grey (1 channel)" : "RGB (3 channels)"));
}

// Stage 3, method: the form-factor method and the generic options every method takes.
void method_stage(Preparation& p) {
  const ProblemSpec& spec = p.spec;
  Problem& problem = p.problem;
  ParamBag ff_bag =
      ParamBag::from_assignments(spec.ff_set, "form factors '" + spec.ff_method + "'");
  // Generic form-factor option (any method): symmetrise the dense matrix after building/loading.
  // On by default for a dense matrix, so shooting, gathering, CG and the reference all solve the
  // same (reciprocal) system (docs/solvers.md); rows computed on the fly cannot be symmetrised.
  p.symmetrise = ff_bag.get_bool("symmetrise", spec.row_mode == RowMode::kCached);
  // Generic: rows above 1 + the method's stated error are refused before the reference unless
  // the user accepts them (then every certificate names the system as unphysical).
  p.accept_unphysical = ff_bag.get_choice("unphysical", "refuse", {"refuse", "accept"}) == "accept";
  // Generic too: the stored precision, as --precision or --ff-set precision=... (the same thing).
  const std::string default_precision = spec.precision == Precision::kDouble ? "double" : "float";
  const std::string precision_name =
      ff_bag.get_choice("precision", default_precision, {"float", "double"});
  p.precision = precision_name == "double" ? Precision::kDouble : Precision::kFloat;
  problem.spec.precision = p.precision;
  problem.method = make_form_factor_method(spec.ff_method, ff_bag, problem.scene(), problem.mesh);
  problem.ff_parameters = problem.method->parameters() + (p.symmetrise ? ",symmetrise=true" : "");
  if (p.symmetrise && spec.row_mode != RowMode::kCached)
    throw UsageError("form factors: symmetrise=true needs the dense matrix (--ff-mode cached)");
  spec.patches.validate();
  // Two levels never symmetrise: no n x n matrix.
  if (spec.patches.two_level()) problem.ff_parameters = problem.method->parameters();
}

// The cache folder and this problem's key in it; the cache holds the method's matrix in double
// (float storage is its rounding, made after loading).
void open_cache(Preparation& p) {
  if (!p.spec.use_cache) return;
  p.cache_dir =
      p.spec.cache_dir.empty() ? default_cache_dir() : std::filesystem::path(p.spec.cache_dir);
  p.cache.emplace(p.cache_dir);
  p.key = matrix_cache_key(p.problem.mesh, p.problem.method->name(), p.problem.method->parameters(),
                           Precision::kDouble);
  p.problem.matrix_cache_file = p.cache->path(p.key).string();
}

// Rows on the fly with a reference in the cache: the reference is certified with the rows the
// method computes, one pass in O(n) memory, and the dense matrix is never built.
void find_streamed_reference(Preparation& p) {
  Problem& problem = p.problem;
  if (!p.spec.need_reference || p.spec.row_mode != RowMode::kOnTheFly || !p.cache) return;
  auto on_the_fly = std::make_unique<System>(problem.scene(), problem.mesh, *problem.method);
  ReferenceCache references(p.cache_dir);
  const ReferenceCacheKey reference_key = reference_cache_key(p.key, false, *on_the_fly, {});
  if (!std::filesystem::exists(references.path(reference_key))) return;
  Progress progress(
      "cached reference, certified with rows on the fly (" + std::to_string(p.n()) + " rows)", "",
      0);
  StreamedCheck check;
  bool stored = false;
  problem.reference =
      references.load(reference_key, *on_the_fly, *problem.method, {}, check, true, stored);
  progress.finish();
  if (!problem.reference) return;
  p.streamed = std::move(check);
  p.streamed_check_stored = stored;
  p.streamed_system = std::move(on_the_fly);
  problem.preparation.push_back(stored ? "reference checked" : "reference streamed");
  problem.reference_cache_file = references.path(reference_key).string();
}

// The n^2 matrix is estimated against the limits before it is allocated and computed: the memory
// is everything the preparation holds at its peak (the matrix in double, its float rounding, the
// reference's LU, the method's buffers, the program), not the solvers' matrix alone.
// The stored size of the matrix the cache holds, or 0.
double cached_matrix_bytes(const Preparation& p) {
  if (!p.cache) return 0.0;
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(p.cache->path(p.key), ec);
  return ec ? 0.0 : double(bytes);
}

// With `stored` > 0 (the cache holds the matrix, that many bytes) it is estimated by its stored
// size instead (a merged soda.mgf matrix is 3% of its dense size), its pairs not computed again.
void check_dense_limits(const Preparation& p, double stored) {
  const double pairs = double(p.n()) * double(p.n());
  ProblemSpec spec = p.spec;
  spec.precision = p.precision;
  if (stored > 0) {
    const PreparationEstimate estimate =
        estimate_cached_preparation(spec, p.n(), stored, preparation_threads());
    check_limit("memory_gb", estimate.total_bytes(),
                p.problem.scene().name + ": the cached form-factor matrix of " +
                    std::to_string(p.n()) + " elements (" + p.cache->path(p.key).string() +
                    ") and what its preparation holds beside it (" + estimate.describe() + ")");
    return;
  }
  const std::string what = p.problem.scene().name + ": the dense form-factor matrix of " +
                           std::to_string(p.n()) + " elements";
  const PreparationEstimate estimate = estimate_preparation(spec, p.n(), preparation_threads());
  check_limit("memory_gb", estimate.total_bytes(),
              what + " and what its preparation holds beside it (" + estimate.describe() + ")");
  check_limit("pairs", pairs, what + " (" + p.spec.ff_method + ")");
}

// The matrix from the cache, with what the method's stated error needs beside it (its side
// files: raycast's per-row visibility errors, exact's pairs stopped short of its tolerance); a
// cached matrix whose method refuses it without them is not used. nullopt on a miss.
std::optional<FormFactorMatrix> load_cached_matrix(Preparation& p) {
  Problem& problem = p.problem;
  BuildReport report = problem.build;
  std::optional<FormFactorMatrix> m = p.cache->load(p.key, &report);
  if (m && !problem.method->load_side_files(p.cache->path(p.key).string(), p.n()))
    return std::nullopt;
  problem.build = std::move(report);
  return m;
}

// The method's matrix in double, built. Sparse: pairs culled or fully occluded cost nothing, and
// no row more than its dense form (formfactor/matrix/matrix.h); the solvers read the same numbers
// either way. A method that integrates each unordered pair once (exact) is built so (the same
// bits as row by row: formfactor/matrix/symmetric_build.h).
FormFactorMatrix build_method_matrix(Problem& problem) {
  const size_t n = problem.mesh.size();
  const bool pairs_once = problem.method->integrates_pairs_once();
  Progress progress("form factors (" + problem.spec.ff_method + ", " + std::to_string(n) + " rows" +
                        (pairs_once ? ", each pair once)" : ")"),
                    pairs_once ? "pairs" : "rows",
                    pairs_once ? 0.5 * double(n) * double(n - 1) : double(n));
  const auto update = [&](size_t done, size_t) { progress.update(double(done)); };
  FormFactorMatrix matrix =
      pairs_once ? build_matrix_symmetric(*problem.method, problem.mesh, Precision::kDouble,
                                          Layout::kSparse, problem.build, update)
                 : build_matrix(*problem.method, n, Precision::kDouble, Layout::kSparse,
                                problem.build, update);
  progress.finish(std::to_string(problem.build.cost.rays) + " visibility rays");
  return matrix;
}

// The method's matrix: loaded from the cache, else built under the key's lock (concurrent
// processes, e.g. shards on an empty cache, build it once; a waiter finds it stored and loads
// it).
void load_or_build_matrix(Preparation& p, double stored) {
  Problem& problem = p.problem;
  std::optional<FormFactorMatrix> cached = p.cache ? load_cached_matrix(p) : std::nullopt;
  if (p.cache && !cached) {
    p.building = p.cache->lock(p.key);
    cached = load_cached_matrix(p);
  }
  if (cached) {
    problem.matrix = std::move(*cached);
    problem.preparation.push_back("matrix loaded");
  } else {
    if (stored > 0) check_dense_limits(p, 0.0);  // the cached file was not usable: a build
    problem.matrix = build_method_matrix(problem);
    problem.preparation.push_back("matrix built");
  }
  log::info("form factors: " + problem.build.summary());
}

// The method's own matrix is checked (and reported) before anything hides its defects; a matrix
// with negative or non-finite entries is never cached or used. Then it is stored with what the
// method keeps beside it, and the lock released.
void check_and_store_matrix(Preparation& p) {
  Problem& problem = p.problem;
  problem.raw_diagnostics = diagnose(problem.matrix, problem.mesh.area);
  if (problem.raw_diagnostics.non_finite_entries > 0 ||
      problem.raw_diagnostics.negative_entries > 0)
    throw NumericalError("form factors '" + p.spec.ff_method +
                         "': " + problem.raw_diagnostics.summary());
  check_row_sums(problem, false);
  log_storage("form factors (double)", problem.matrix);
  if (p.cache && !problem.build.cached && p.cache->store(p.key, problem.matrix, problem.build)) {
    problem.build.cache_file = p.cache->path(p.key).string();
    problem.method->save_side_files(problem.build.cache_file);
  }
  p.building.reset();
}

// The matrix the solvers read, from the method's: symmetrised (if asked) and rounded to float
// (float storage; the reference and bounds stay on the double one, the system the method
// computed: docs/reference.md), with its diagnostics and row sums.
void derive_solver_matrix(Preparation& p) {
  Problem& problem = p.problem;
  const bool symmetrised = p.symmetrise, to_float = p.precision == Precision::kFloat;
  if (symmetrised) {
    log::info("form factors (as computed): " + problem.raw_diagnostics.summary());
    symmetrise(problem.matrix, problem.mesh.area);
  }
  if (to_float && p.spec.row_mode == RowMode::kCached) {
    FormFactorMatrix rounded = convert_precision(problem.matrix, Precision::kFloat);
    // Without a reference nothing is certified: the double matrix is not kept.
    if (p.spec.need_reference) problem.computed = std::move(problem.matrix);
    problem.matrix = std::move(rounded);
  }
  if (problem.computed.size() > 0) log_storage("form factors (float)", problem.matrix);
  if (symmetrised || to_float) {
    problem.diagnostics = diagnose(problem.matrix, problem.mesh.area);
    log::info(std::string("form factors (") + (symmetrised ? "symmetrised" : "") +
              (symmetrised && to_float ? ", " : "") + (to_float ? "stored in float" : "") +
              "): " + problem.diagnostics.summary());
    check_row_sums(problem, true);
  } else {
    problem.diagnostics = problem.raw_diagnostics;
    log::info("form factors: " + problem.diagnostics.summary());
    problem.used_row_sums = problem.row_sums;
  }
}

// Stage 4, matrix (cached): the dense matrix when rows are cached or the reference needs it (a
// streaming run without a reference never holds n^2 numbers, nor one whose reference the cache
// holds).
void matrix_stage(Preparation& p) {
  open_cache(p);
  find_streamed_reference(p);
  const bool dense = p.spec.row_mode == RowMode::kCached || (p.spec.need_reference && !p.streamed);
  if (!dense) return;
  const double stored = cached_matrix_bytes(p);
  check_dense_limits(p, stored);
  load_or_build_matrix(p, stored);
  check_and_store_matrix(p);
  derive_solver_matrix(p);
}

// Stage 5, checks: the physical checks before the reference (refuse_unphysical), from the dense
// matrix or, for a reference certified with rows on the fly, from the same pass (rows summing
// above 1 + the stated error, the emitters' power).
void checks_stage(Preparation& p) {
  Problem& problem = p.problem;
  if (!p.spec.need_reference) return;
  if (!p.streamed) {
    refuse_unphysical(problem, p.accept_unphysical,
                      emitted_power_ratio(problem.matrix, problem.scene(), problem.mesh));
    check_emitter_sampling(problem);
    return;
  }
  const StreamedCheck& streamed = *p.streamed;
  const size_t n = p.n();
  // The dense check's limits (formfactor/matrix/diagnostics.h), from the pass's row sums.
  problem.row_sums = check_row_sums(streamed.row_sum, *problem.method);
  problem.used_row_sums = problem.row_sums;
  const System& system = *p.streamed_system;
  double sent = 0.0, gathered = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double e = 0.0;
    for (int c = 0; c < system.channels(); ++c) e += system.emission().at(c, i);
    sent += e * problem.mesh.area[i] * streamed.row_sum[i];
    gathered += problem.mesh.area[i] * streamed.emitter_sum[i];
  }
  refuse_unphysical(problem, p.accept_unphysical,
                    sent > 0 ? gathered / sent : (gathered > 0 ? 1e300 : 1.0));
  check_emitter_sampling(problem);
}

// What the certificate is of: the method's F in double, symmetrised or not, how the solvers read
// it, and whether it was accepted as unphysical (docs/reference.md).
std::string certified_system_text(const Preparation& p) {
  return "F of " + p.spec.ff_method + " in double precision, as computed" +
         (p.symmetrise ? ", then symmetrised (symmetrise=true, the default with cached rows: a "
                         "chosen change of the system; symmetrise=false certifies the method's own)"
                       : "") +
         (p.precision == Precision::kFloat ? "; solvers read it rounded to float" : "") +
         (p.accept_unphysical && !p.problem.row_sums.ok()
              ? "; UNPHYSICAL: rows of F above 1 + the method's stated error, accepted with "
                "unphysical=accept"
              : "") +
         (!p.streamed ? ""
          : p.streamed_check_stored
              ? "; rows computed on the fly, the cached reference certified by the residual pass "
                "stored with it (the same rows, computed once; key, solution and checksum "
                "verified)"
              : "; rows computed on the fly, the cached reference certified against them");
}

// Stage 6, reference (cached): certified anew when loaded; computed under the key's lock on a
// miss (as the matrix: computed once, others wait) and stored. Then what the certificate is of.
void reference_stage(Preparation& p) {
  Problem& problem = p.problem;
  if (!p.streamed) {
    Progress progress("reference solution (" + std::to_string(p.n()) + " elements)", "", 0);
    const FormFactorMatrix& certified = problem.certified_matrix();
    System cached(problem.scene(), problem.mesh, certified);
    std::optional<ReferenceCache> references;
    ReferenceCacheKey reference_key;
    if (p.cache) {
      references.emplace(p.cache_dir);
      reference_key = reference_cache_key(p.key, p.symmetrise, cached, {});
      problem.reference_cache_file = references->path(reference_key).string();
      problem.reference = references->load(reference_key, cached, certified, {});
    }
    std::unique_ptr<FileLock> computing;
    if (references && !problem.reference) {
      computing = references->lock(reference_key);
      problem.reference = references->load(reference_key, cached, certified, {});
    }
    if (!problem.reference) {
      try {
        problem.reference = compute_reference(cached, certified);
      } catch (const NumericalError& e) {  // name F's row sums beside the spectral radius
        throw NumericalError(std::string(e.what()) + " [" + problem.used_row_sums.headline() + "]");
      }
      if (references) references->store(reference_key, *problem.reference);
      problem.preparation.push_back("reference computed");
    } else {
      problem.preparation.push_back("reference loaded");
    }
    // The method's own rows (not symmetrised) are the rows a run on the fly computes: store their
    // residual pass now, from the matrix in memory, so that such a run certifies the reference
    // without computing every row again. A stored pass that is missing, damaged or of another B
    // (load_check refuses it) is replaced: here it costs one product, there every row.
    if (references && !p.symmetrise && !references->load_check(reference_key, problem.reference->B))
      references->store_check(reference_key, problem.reference->B,
                              matrix_check(cached, certified, problem.reference->B));
    progress.finish();
  }
  problem.reference->system = certified_system_text(p);
  if (problem.computed.size() > 0)  // float storage: the solvers' floor (issue 35.6)
    bound_storage_rounding(System(problem.scene(), problem.mesh, problem.matrix), problem.computed,
                           problem.matrix, *problem.reference);
  log::info("reference: " + problem.reference->summary());
}

// Stage 7, system: what the solvers read, rows from the matrix or on the fly (RowMode).
void system_stage(Preparation& p) {
  Problem& problem = p.problem;
  if (p.spec.row_mode == RowMode::kCached)
    problem.system = std::make_unique<System>(problem.scene(), problem.mesh, problem.matrix);
  else
    problem.system = std::make_unique<System>(problem.scene(), problem.mesh, *problem.method);
}

// Two levels (two_level_problem.h): the patch rows in the matrix's place, their checks, the
// rank-P reference, the system on the rows. Nothing n x n.
void two_level_rows_stage(Preparation& p) {
  two_level_patch_rows(p.problem);
  p.problem.preparation.push_back("patch rows built");
}
void two_level_checks_stage(Preparation& p) {
  check_two_level_rows(p.problem, p.accept_unphysical);
}
void two_level_reference_stage(Preparation& p) {
  two_level_reference(p.problem, p.accept_unphysical);
}
void two_level_system_stage(Preparation& p) {
  two_level_system(p.problem);
}

// The stages after the method, by the shape of the system: one level (the n x n matrix) or two
// (patch rows).
struct Stages {
  void (*matrix)(Preparation&);
  void (*checks)(Preparation&);
  void (*reference)(Preparation&);
  void (*system)(Preparation&);
};
constexpr Stages kOneLevel{matrix_stage, checks_stage, reference_stage, system_stage};
constexpr Stages kTwoLevels{two_level_rows_stage, two_level_checks_stage, two_level_reference_stage,
                            two_level_system_stage};

// Every preparation starts so: the scene, its mesh, the form-factor method on it.
void method_stages(Preparation& p) {
  scene_stage(p);
  mesh_stage(p);
  method_stage(p);
}

// The method's stages, then the cache and the key a blocked build works on.
std::unique_ptr<Problem> prepare_for_blocks(const ProblemSpec& spec, MatrixCache& cache,
                                            MatrixCacheKey& key) {
  if (spec.patches.two_level())
    throw UsageError("blocks: two-level problems have no n x n matrix to build in blocks");
  if (!spec.use_cache) throw UsageError("blocks: a blocked build needs the cache (not --no-cache)");
  auto problem = prepare_method(spec);
  block_split(*problem->method, spec.ff_method);  // refused here when not built in blocks
  Preparation p{*problem, spec};
  open_cache(p);
  cache = *p.cache;
  key = p.key;
  return problem;
}

}  // namespace

std::unique_ptr<Problem> prepare_method(const ProblemSpec& spec) {
  auto problem = std::make_unique<Problem>();
  problem->spec = spec;
  Preparation p{*problem, spec};
  method_stages(p);
  return problem;
}

std::unique_ptr<Problem> prepare_matrix_block(const ProblemSpec& spec, size_t index, size_t count,
                                              MatrixBlock* built) {
  MatrixCache cache{std::filesystem::path()};
  MatrixCacheKey key;
  auto problem = prepare_for_blocks(spec, cache, key);
  const BlockSplit split = block_split(*problem->method, spec.ff_method);
  // Blocks of pairs are cut by the method's estimated work, as the merge and the plan cut them.
  std::optional<PairWorkSplit> work;
  if (split == BlockSplit::kPairs) work = pair_work_split(*problem->method, problem->mesh.size());
  const MatrixBlock block =
      matrix_block(problem->mesh.size(), index, count, split, work ? &*work : nullptr);
  if (built) *built = block;
  // The limits hold for the block's own work and memory, by the plan's estimate (the merge is
  // checked by the merge's).
  const PreparationEstimate estimate = estimate_matrix_block(
      spec, problem->mesh.size(), block, preparation_threads(), work ? &*work : nullptr);
  const std::string what = problem->scene().name + ": " + block.label() + " of the form-factor " +
                           "matrix of " + std::to_string(problem->mesh.size()) + " elements";
  check_limit("memory_gb", estimate.total_bytes(), what + " (" + estimate.describe() + ")");
  check_limit("pairs", block.entries(), what + " (" + spec.ff_method + ")");
  Progress progress("form factors (" + spec.ff_method + ", " + block.label() + ")", "rows",
                    double(block.end - block.first));
  build_matrix_block(*problem->method, cache, key, problem->mesh.size(), block, problem->build,
                     [&](size_t done, size_t) { progress.update(double(done)); });
  progress.finish(std::to_string(problem->build.cost.rays) + " visibility rays");
  problem->preparation.push_back("matrix block built");
  log::info("form factors: " + block.label() + " in " + problem->build.cache_file + ": " +
            problem->build.summary());
  return problem;
}

void merge_matrix_blocks(const ProblemSpec& spec, size_t count) {
  MatrixCache cache{std::filesystem::path()};
  MatrixCacheKey key;
  auto problem = prepare_for_blocks(spec, cache, key);
  const size_t n = problem->mesh.size();
  std::optional<PairWorkSplit> work;
  if (block_split(*problem->method, spec.ff_method) == BlockSplit::kPairs)
    work = pair_work_split(*problem->method, n);
  // The merge and the preparation after it, by the plan's estimate of the blocks' stored size
  // (their files: the merged matrix's entries; a missing block is refused by the merge).
  double stored = 0.0;
  for (const MatrixBlock& block : matrix_blocks(
           n, count, block_split(*problem->method, spec.ff_method), work ? &*work : nullptr)) {
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(matrix_block_file(cache, key, block), ec);
    if (!ec) stored += double(bytes);
  }
  const PreparationEstimate estimate =
      estimate_block_merge(spec, n, preparation_threads(), work ? &*work : nullptr, stored);
  check_limit("memory_gb", estimate.total_bytes(),
              problem->scene().name + ": the merge of " + std::to_string(count) +
                  " blocks of the form-factor matrix of " + std::to_string(n) +
                  " elements and its preparation (" + estimate.describe() + ")");
  const std::unique_ptr<FileLock> lock = cache.lock(key);
  const MergedMatrix merged =
      merge_matrix_blocks(*problem->method, cache, key, n, count, work ? &*work : nullptr);
  if (!store_merged_matrix(*problem->method, cache, key, merged))
    throw InputError(cache.path(key).string() +
                     ": cannot store the merged matrix (see the warning above)");
  log::info("form factors: " + std::to_string(count) + " blocks merged into " +
            cache.path(key).string());
}

std::unique_ptr<Problem> prepare_problem(const ProblemSpec& spec) {
  auto problem = std::make_unique<Problem>();
  problem->spec = spec;
  Preparation p{*problem, spec};
  method_stages(p);
  const Stages& stages = spec.patches.two_level() ? kTwoLevels : kOneLevel;
  stages.matrix(p);
  stages.checks(p);
  if (spec.need_reference) stages.reference(p);
  stages.system(p);
  return problem;
}

}  // namespace radlab
