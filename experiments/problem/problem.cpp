#include "experiments/problem/problem.h"

#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "core/limits.h"
#include "core/log.h"
#include "core/progress.h"
#include "experiments/problem/reference_cache.h"
#include "experiments/problem/two_level_problem.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/matrix/symmetric_build.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/raycast.h"

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

}  // namespace

std::unique_ptr<Problem> prepare_problem(const ProblemSpec& spec) {
  auto problem = std::make_unique<Problem>();
  problem->spec = spec;
  problem->loaded = load_scene(spec.scene, true, spec.keep_overlaps);
  if (spec.require_emitter) require_emitter(problem->scene());
  if (spec.mesh.subdivisions < 1) throw UsageError("--subdiv must be >= 1");
  if (spec.mesh.element_size < 0) throw UsageError("--element-size must be > 0");
  problem->mesh = build_mesh(problem->scene(), spec.mesh);
  log::info(problem->scene().name + ": " + std::to_string(problem->scene().polygons.size()) +
            " polygons, " + std::to_string(problem->mesh.size()) + " elements, " +
            (problem->scene().is_grey() ? "grey (1 channel)" : "RGB (3 channels)"));

  ParamBag ff_bag =
      ParamBag::from_assignments(spec.ff_set, "form factors '" + spec.ff_method + "'");
  // Generic form-factor option (any method): symmetrise the dense matrix after building/loading.
  // On by default for a dense matrix, so shooting, gathering, CG and the reference all solve the
  // same (reciprocal) system (docs/solvers.md); rows computed on the fly cannot be symmetrised.
  const bool symmetrise_ff = ff_bag.get_bool("symmetrise", spec.row_mode == RowMode::kCached);
  // Generic: rows above 1 + the method's stated error are refused before the reference unless
  // the user accepts them (then every certificate names the system as unphysical).
  const bool accept_unphysical =
      ff_bag.get_choice("unphysical", "refuse", {"refuse", "accept"}) == "accept";
  // Generic too: the stored precision, as --precision or --ff-set precision=... (the same thing).
  const std::string default_precision = spec.precision == Precision::kDouble ? "double" : "float";
  const std::string precision_name =
      ff_bag.get_choice("precision", default_precision, {"float", "double"});
  const Precision precision = precision_name == "double" ? Precision::kDouble : Precision::kFloat;
  problem->spec.precision = precision;
  problem->method =
      make_form_factor_method(spec.ff_method, ff_bag, problem->scene(), problem->mesh);
  problem->ff_parameters =
      problem->method->parameters() + (symmetrise_ff ? ",symmetrise=true" : "");
  if (symmetrise_ff && spec.row_mode != RowMode::kCached)
    throw UsageError("form factors: symmetrise=true needs the dense matrix (--ff-mode cached)");

  // Two levels: patch rows and the rank-P reference, no n x n matrix (two_level_problem.h).
  spec.patches.validate();
  if (spec.patches.two_level()) {
    problem->ff_parameters = problem->method->parameters();
    prepare_two_level(*problem, accept_unphysical);
    return problem;
  }

  const size_t n = problem->mesh.size();
  // The dense matrix is built when rows are cached or the reference needs it; a streaming run
  // without a reference never holds n^2 numbers.
  std::filesystem::path cache_dir;
  if (spec.use_cache)
    cache_dir =
        spec.cache_dir.empty() ? default_cache_dir() : std::filesystem::path(spec.cache_dir);
  std::optional<MatrixCache> cache;
  MatrixCacheKey key;
  if (!cache_dir.empty()) {
    cache.emplace(cache_dir);
    // The cache holds the method's matrix in double; float storage is its rounding, made below.
    key = matrix_cache_key(problem->mesh, problem->method->name(), problem->method->parameters(),
                           Precision::kDouble);
    problem->matrix_cache_file = cache->path(key).string();
  }
  // Rows on the fly with a reference in the cache: the reference is certified with the rows the
  // method computes, one pass in O(n) memory, and the dense matrix is never built.
  spec.patches.validate();
  const bool two_level = spec.patches.two_level();
  std::optional<StreamedCheck> streamed;
  if (spec.need_reference && spec.row_mode == RowMode::kOnTheFly && cache && !two_level) {
    System on_the_fly(problem->scene(), problem->mesh, *problem->method);
    ReferenceCache references(cache_dir);
    const ReferenceCacheKey reference_key = reference_cache_key(key, false, on_the_fly, {});
    if (std::filesystem::exists(references.path(reference_key))) {
      Progress progress(
          "cached reference, certified with rows on the fly (" + std::to_string(n) + " rows)", "",
          0);
      StreamedCheck check;
      problem->reference = references.load(reference_key, on_the_fly, *problem->method, {}, check);
      progress.finish();
      if (problem->reference) {
        streamed = std::move(check);
        problem->reference_cache_file = references.path(reference_key).string();
      }
    }
  }
  const bool dense = spec.row_mode == RowMode::kCached || (spec.need_reference && !streamed);
  if (dense) {
    // Estimated before the n^2 allocation and the n^2 pair evaluations.
    const double pairs = double(n) * double(n);
    const std::string what = problem->scene().name + ": the dense form-factor matrix of " +
                             std::to_string(n) + " elements";
    check_limit("memory_gb", pairs * (precision == Precision::kDouble ? 8.0 : 4.0), what);
    check_limit("pairs", pairs, what + " (" + spec.ff_method + ")");
  }
  if (dense) {
    // exact's clip mode states the remaining error of pairs stopped short of its tolerance, kept
    // beside the matrix: a cached matrix without it is not used.
    const auto* clip = dynamic_cast<const ExactFormFactors*>(problem->method.get());
    if (clip && !clip->records_row_excess()) clip = nullptr;
    const auto load = [&]() -> std::optional<FormFactorMatrix> {
      BuildReport report = problem->build;
      std::optional<FormFactorMatrix> m = cache->load(key, &report);
      if (m && clip && !load_row_excess(*clip, cache->path(key).string(), n)) return std::nullopt;
      problem->build = std::move(report);
      return m;
    };
    std::optional<FormFactorMatrix> cached = cache ? load() : std::nullopt;
    // A miss: hold the key's lock while building and storing, so that concurrent processes
    // (shards on an empty cache) build the matrix once; a waiter finds it stored and loads it.
    std::unique_ptr<FileLock> building;
    if (cache && !cached) {
      building = cache->lock(key);
      cached = load();
    }
    if (cached) {
      problem->matrix = std::move(*cached);
      // raycast's per-row visibility errors, kept beside the matrix (else rows the check needs
      // are recomputed)
      if (auto* raycast = dynamic_cast<const RaycastFormFactors*>(problem->method.get()))
        load_row_sampling_errors(*raycast, cache->path(key).string(), n);
      log::info("form factors: " + problem->build.summary());
    } else {
      // Sparse: pairs culled or fully occluded cost nothing, and no row more than its dense form
      // (formfactor/matrix/matrix.h); the solvers read the same numbers either way. `exact`
      // integrates each unordered pair once (the same bits as row by row:
      // formfactor/matrix/symmetric_build.h).
      const auto* exact = dynamic_cast<const ExactFormFactors*>(problem->method.get());
      Progress progress("form factors (" + spec.ff_method + ", " + std::to_string(n) + " rows" +
                            (exact ? ", each pair once)" : ")"),
                        exact ? "pairs" : "rows",
                        exact ? 0.5 * double(n) * double(n - 1) : double(n));
      const auto update = [&](size_t done, size_t) { progress.update(double(done)); };
      problem->matrix = exact ? build_matrix_symmetric(*exact, problem->mesh, Precision::kDouble,
                                                       Layout::kSparse, problem->build, update)
                              : build_matrix(*problem->method, n, Precision::kDouble,
                                             Layout::kSparse, problem->build, update);
      progress.finish(std::to_string(problem->build.cost.rays) + " visibility rays");
      log::info("form factors: " + problem->build.summary());
    }
    // The method's own matrix is checked (and reported) before anything hides its defects; a
    // matrix with negative or non-finite entries is never cached or used.
    problem->raw_diagnostics = diagnose(problem->matrix, problem->mesh.area);
    if (problem->raw_diagnostics.non_finite_entries > 0 ||
        problem->raw_diagnostics.negative_entries > 0)
      throw NumericalError("form factors '" + spec.ff_method +
                           "': " + problem->raw_diagnostics.summary());
    check_row_sums(*problem, false);
    log_storage("form factors (double)", problem->matrix);
    if (cache && !problem->build.cached && cache->store(key, problem->matrix, problem->build)) {
      problem->build.cache_file = cache->path(key).string();
      if (auto* raycast = dynamic_cast<const RaycastFormFactors*>(problem->method.get()))
        save_row_sampling_errors(*raycast, problem->build.cache_file);
      if (clip) save_row_excess(*clip, problem->build.cache_file);
    }
    building.reset();
    if (symmetrise_ff) {
      log::info("form factors (as computed): " + problem->raw_diagnostics.summary());
      symmetrise(problem->matrix, problem->mesh.area);
    }
    // Float storage: the solvers read the rounding of the double matrix, and the reference and
    // bounds stay on the double one (the system the method computed; docs/reference.md).
    if (precision == Precision::kFloat && spec.row_mode == RowMode::kCached) {
      FormFactorMatrix rounded = convert_precision(problem->matrix, Precision::kFloat);
      // Without a reference nothing is certified: the double matrix is not kept.
      if (spec.need_reference) problem->computed = std::move(problem->matrix);
      problem->matrix = std::move(rounded);
    }
    if (problem->computed.size() > 0) log_storage("form factors (float)", problem->matrix);
    if (symmetrise_ff || precision == Precision::kFloat) {
      problem->diagnostics = diagnose(problem->matrix, problem->mesh.area);
      log::info(std::string("form factors (") + (symmetrise_ff ? "symmetrised" : "") +
                (symmetrise_ff && precision == Precision::kFloat ? ", " : "") +
                (precision == Precision::kFloat ? "stored in float" : "") +
                "): " + problem->diagnostics.summary());
      check_row_sums(*problem, true);
    } else {
      problem->diagnostics = problem->raw_diagnostics;
      log::info("form factors: " + problem->diagnostics.summary());
      problem->used_row_sums = problem->row_sums;
    }
  }

  if (spec.row_mode == RowMode::kCached)
    problem->system = std::make_unique<System>(problem->scene(), problem->mesh, problem->matrix);
  else
    problem->system = std::make_unique<System>(problem->scene(), problem->mesh, *problem->method);

  if (spec.need_reference && streamed) {
    // The checks of a dense build, from the same pass (rows summing above 1 + the stated error,
    // the emitters' power), then the certificate's wording.
    RowSumCheck& sums = problem->row_sums;
    sums.stated_error = stated_row_sum_error(*problem->method);
    sums.row_sum_min =
        n ? *std::min_element(streamed->row_sum.begin(), streamed->row_sum.end()) : 0.0;
    sums.row_sum_max =
        n ? *std::max_element(streamed->row_sum.begin(), streamed->row_sum.end()) : 0.0;
    for (double v : streamed->row_sum) sums.rows_above += v > 1.0 + sums.stated_error;
    problem->used_row_sums = sums;
    double sent = 0.0, gathered = 0.0;
    for (size_t i = 0; i < n; ++i) {
      double e = 0.0;
      for (int c = 0; c < problem->system->channels(); ++c)
        e += problem->system->emission().at(c, i);
      sent += e * problem->mesh.area[i] * streamed->row_sum[i];
      gathered += problem->mesh.area[i] * streamed->emitter_sum[i];
    }
    refuse_unphysical(*problem, accept_unphysical,
                      sent > 0 ? gathered / sent : (gathered > 0 ? 1e300 : 1.0));
  } else if (spec.need_reference) {
    Progress progress("reference solution (" + std::to_string(n) + " elements)", "", 0);
    const FormFactorMatrix& certified = problem->certified_matrix();
    System cached(problem->scene(), problem->mesh, certified);
    std::optional<ReferenceCache> references;
    ReferenceCacheKey reference_key;
    if (cache) {
      references.emplace(cache_dir);
      reference_key = reference_cache_key(key, symmetrise_ff, cached, {});
      problem->reference_cache_file = references->path(reference_key).string();
      problem->reference = references->load(reference_key, cached, certified, {});
    }
    std::unique_ptr<FileLock> computing;  // as for the matrix: computed once, others wait
    if (references && !problem->reference) {
      computing = references->lock(reference_key);
      problem->reference = references->load(reference_key, cached, certified, {});
    }
    refuse_unphysical(*problem, accept_unphysical,
                      emitted_power_ratio(problem->matrix, problem->scene(), problem->mesh));
    if (!problem->reference) {
      try {
        problem->reference = compute_reference(cached, certified);
      } catch (const NumericalError& e) {  // name F's row sums beside the spectral radius
        throw NumericalError(std::string(e.what()) + " [" + problem->used_row_sums.headline() +
                             "]");
      }
      if (references) references->store(reference_key, *problem->reference);
    }
    computing.reset();
    progress.finish();
  }
  if (spec.need_reference) {
    problem->reference->system =
        "F of " + spec.ff_method + " in double precision, as computed" +
        (symmetrise_ff ? ", then symmetrised (symmetrise=true, the default with cached rows: a "
                         "chosen change of the system; symmetrise=false certifies the method's own)"
                       : "") +
        (precision == Precision::kFloat ? "; solvers read it rounded to float" : "") +
        (accept_unphysical && !problem->row_sums.ok()
             ? "; UNPHYSICAL: rows of F above 1 + the method's stated error, accepted with "
               "unphysical=accept"
             : "");
    if (streamed)
      problem->reference->system +=
          "; rows computed on the fly, the cached reference certified against them";
    if (problem->computed.size() > 0)  // float storage: the solvers' floor (issue 35.6)
      bound_storage_rounding(*problem->system, problem->computed, problem->matrix,
                             *problem->reference);
    log::info("reference: " + problem->reference->summary());
  }
  return problem;
}

}  // namespace radlab
