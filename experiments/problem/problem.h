// Everything a run needs, prepared once per scene + mesh + form-factor method and shared by all
// the runs on it: the validated scene, its mesh, the form-factor method, the dense matrix (when
// rows are cached), the System, and the certified reference.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/diagnostics.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/registry.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
#include "solvers/reference/reference.h"
#include "solvers/system.h"
#include "solvers/two_level/patch_rows.h"
#include "solvers/two_level/patches.h"

namespace radlab {

struct MatrixBlock;

enum class RowMode { kCached, kOnTheFly };

struct ProblemSpec {
  std::string scene;           // builtin:NAME[:k=v,...] or a file
  bool keep_overlaps = false;  // coincident polygons as they are (scene/overlap.h)
  MeshOptions mesh;            // --subdiv / --element-size
  std::string ff_method = kDefaultFormFactorMethod;
  std::vector<std::string> ff_set;  // --ff-set k=v
  Precision precision = Precision::kFloat;
  RowMode row_mode = RowMode::kCached;
  bool need_reference = true;
  bool require_emitter = true;
  bool use_cache =
      true;  // dense matrices from/to the on-disk cache (formfactor/matrix/matrix_cache.h)
  std::string cache_dir;  // the cache folder; empty: $RADLAB_CACHE_DIR or ~/.cache/radlab
  PatchOptions patches;  // two levels (solvers/two_level/patches.h); default: one patch per element
};

struct Problem {
  ProblemSpec spec;
  LoadedScene loaded;
  Mesh mesh;
  std::unique_ptr<FormFactorMethod> method;
  std::string ff_parameters;  // resolved, canonical
  FormFactorMatrix matrix;    // what the solvers read; empty (size 0) for streaming runs
                              // without a reference; with patches, the two-level K
  // The method's matrix in double precision when `matrix` is its float rounding (--precision
  // float with cached rows); empty otherwise. The reference and every certified bound are of
  // this system, the one the method computed, whatever the storage (docs/reference.md). With
  // patches, the two-level K formed from it.
  FormFactorMatrix computed;
  // Two levels only (experiments/problem/two_level_problem.h): the patches, their rows as the
  // solvers read them and in double (what the reference certifies), K's rows served from them, and
  // the cost of the patch rows. No n x n matrix then (has_matrix() is false).
  Patches patches;
  RowMatrix patch_rows, certified_patch_rows;
  std::unique_ptr<FormFactorMethod> gather_rows;
  PatchRowReport patch_row_report;
  BuildReport build;
  MatrixDiagnostics diagnostics;           // of the matrix the solvers use (symmetrised if asked)
  MatrixDiagnostics raw_diagnostics;       // of the matrix as the method computed it
  RowSumCheck row_sums;                    // rows of the computed matrix above 1 + stated error
  RowSumCheck used_row_sums;               // the same for the matrix the solvers use
  EmitterSamplingReport emitter_sampling;  // methods that sample sources from a point (hemicube)
  std::unique_ptr<System> system;          // rows from the matrix, or on the fly (RowMode)
  std::optional<Reference> reference;
  // Where the cache holds (or would hold) the matrix and reference; empty without a cache.
  std::string matrix_cache_file, reference_cache_file;
  // What preparing it did, in order, one word each (run.json's problem.preparation; tests assert
  // on it): "matrix built", "matrix loaded" (from the cache), "reference computed",
  // "reference loaded" (certified anew against the matrix), "reference streamed" (loaded from the
  // cache, certified with rows on the fly: no matrix), "reference checked" (loaded from the cache,
  // certified by the residual pass stored with it: no matrix, no rows), "patch rows built" (two
  // levels).
  std::vector<std::string> preparation;

  const Scene& scene() const { return loaded.scene; }
  bool has_matrix() const { return matrix.size() > 0; }
  // The matrix the reference solves and certifies against: always double precision.
  const FormFactorMatrix& certified_matrix() const {
    return computed.size() > 0 ? computed : matrix;
  }
};

// Loads, meshes, builds the matrix (with progress on stderr) and, if asked, the reference.
std::unique_ptr<Problem> prepare_problem(const ProblemSpec& spec);

// The first stages alone: the scene, its mesh and the form-factor method (nothing n x n).
std::unique_ptr<Problem> prepare_method(const ProblemSpec& spec);

// Blocked matrix builds (formfactor/matrix/matrix_blocks.h: `radlab prepare --block`, the
// workflow's block jobs). prepare_matrix_block: the method's stages, then block `index` of
// `count` of its matrix computed into the cache (problem->build is the block's, its cache_file
// the block file). merge_matrix_blocks: the `count` blocks checked and merged into the cached
// matrix under the matrix's lock; prepare_problem then loads it as any cached matrix. Both
// refuse (UsageError) two-level problems, a spec without a cache and methods that are not built
// in blocks.
// `built`, if given, receives the block (its rows, its share of the estimated work).
std::unique_ptr<Problem> prepare_matrix_block(const ProblemSpec& spec, size_t index, size_t count,
                                              MatrixBlock* built = nullptr);
void merge_matrix_blocks(const ProblemSpec& spec, size_t count);

}  // namespace radlab
