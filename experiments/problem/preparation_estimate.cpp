#include "experiments/problem/preparation_estimate.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "core/text.h"
#include "formfactor/registry.h"
#include "solvers/reference/reference.h"

namespace radlab {
namespace {

// Measured on this machine (docs/reliability.md, scripts/measure_estimates.py), rounded up: the
// program with a small scene peaks at ~22 MB; a mesh element with its vertices, Embree's BVH and
// the per-element arrays of the matrix build and the system: `prepare --plan` alone (scene, mesh,
// the method's tables) peaks at 123 MB at hosp.mgf (12,530 elements) and 290 MB at soda.mgf
// (53,216), 4.1 kB an element above 71 MB.
constexpr double kProgramBytes = 80e6;
constexpr double kBytesPerElement = 4.2e3;
// Process start, scene, mesh and Embree: under a second for the scenes radlab ships.
constexpr double kStartSeconds = 1.0;
// The times are of the whole machine (not divided by the threads: a node shared with other jobs
// gives fewer than it has). Dense form factors, per pair (raycast's default settings).
constexpr double kSecondsPerPair = 1e-6;
// LU: n^3/3 multiply-adds at 1 ns.
constexpr double kSecondsPerLuFlop = 1e-9;
// Hemicube, per row: each of the 3R^2 pixels is cleared, depth-tested and summed (20 ns a pixel
// bounds what was measured on 2 threads of a loaded machine), each element projected and clipped.
constexpr double kSecondsPerHemicubePixel = 20e-9;
constexpr double kSecondsPerHemicubeElement = 1e-6;
// A merge of blocks reads the matrix's bytes from the cache folder: 100 MB/s bounds a shared
// (NFS) file system from below; a local disk reads faster.
constexpr double kBlockReadBytesPerSecond = 100e6;
// raycast's and exact's adaptive quadrature keeps its heap of cells per thread (thread_local,
// never shrunk): a close pair refined to the evaluation cap leaves it at its largest. Measured
// as the peak above the program of hosp.mgf's blocks: 0, 61 or 109 MB, the last twice (blocks
// holding pairs of large elements in contact); rounded up. (The cap, 2e7 evaluations, would
// allow a few times more; not seen.)
constexpr double kQuadratureBytesPerThread = 128e6;
// A block or merge process's start beyond kStartSeconds, per element: the scene, its mesh, the
// BVH, the method's tables and the work estimate (soda.mgf, 53,216 elements: about 6 s).
constexpr double kStartSecondsPerElement = 1.2e-4;
// The share of the facing pairs' entries that are non-zero (some ray joins the pair), for the
// estimates made before the entries exist: measured 13% at hosp.mgf and 6% at soda.mgf (a
// building's walls hide most of what faces), rounded up. A scene with few occluders (the
// Cornell box) has most facing pairs visible: there this underestimates the entries.
constexpr double kStoredShareOfFacing = 0.15;
// A block of pairs holds its non-zero entries three times (the pairs' upper and lower rows, then
// the assembled rows), in double with their runs (16 bytes an entry at most): 7.2 bytes per
// entry of its facing pairs. Measured peaks less the program and the quadrature heap: hosp's
// blocks of 8 at most 2 MB over it (plan 72 MB for block 8), soda's blocks of 64 none.
constexpr double kPairBlockBytesPerEntry = 3.0 * 16.0 * kStoredShareOfFacing;
// A merge holds every entry twice (the blocks' rows gathered, the rows assembled) with their
// runs, and one block read at a time: 1.5 times the blocks' stored bytes.
constexpr double kMergeBytesPerStoredByte = 1.5;
// A stored sparse entry: 8 bytes in double, and a run (two uint32) at most every entry.
constexpr double kStoredBytesPerEntry = 16.0;
// The certified reference above the dense limit: GMRES(30)'s basis and a few more vectors of n
// doubles, per channel solve; its time per channel and stored entry (GMRES's products, the
// refinements' long-double residuals, the float-storage bound): hosp.mgf's merge (12,530
// elements, 40.9 MB stored, 3 channels, 3 refinements of ~20 GMRES iterations) took 31.9 CPU s
// on one thread with its checks, 2.0 us a channel-entry; rounded up.
constexpr double kGmresVectors = 40.0;
constexpr double kReferenceSecondsPerChannelEntry = 2.5e-6;

// The method's parameter `key`: from spec.ff_set (key=value), else the method's default.
std::string method_parameter(const ProblemSpec& spec, const std::string& key) {
  for (const std::string& assignment : spec.ff_set)
    if (text::starts_with(assignment, key + "=")) return assignment.substr(key.size() + 1);
  try {
    const auto defaults = read_parameter_defaults(form_factor_method_info(spec.ff_method));
    auto it = defaults.find(key);
    return it == defaults.end() ? std::string() : it->second;
  } catch (const Error&) {
    return std::string();  // an unknown method is refused where it is made
  }
}

std::string megabytes(double bytes) {
  return text::format_double(std::ceil(bytes / 1e6)) + " MB";
}

}  // namespace

int preparation_threads() {
  return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

std::string PreparationEstimate::describe() const {
  std::string text = "matrix " + megabytes(matrix_bytes);
  if (float_bytes > 0) text += " + float copy " + megabytes(float_bytes);
  if (reference_bytes > 0) text += " + reference LU " + megabytes(reference_bytes);
  if (method_bytes > 0) text += " + form-factor method " + megabytes(method_bytes);
  return text + " + program, scene and mesh " + megabytes(program_bytes);
}

namespace {

// The form-factor method's part for `rows` of the n rows: its working memory (into e) and the
// seconds of those rows.
double matrix_rows(const ProblemSpec& spec, double n, double rows, double threads,
                   PreparationEstimate& e) {
  if (spec.ff_method == "hemicube") {
    // Per thread an item buffer and a depth buffer (4 + 4 bytes) over the 3R^2 pixels of the top
    // face and four half faces; the delta form factors (8 bytes a pixel) twice, the method's
    // copy and the process-wide cache it comes from.
    const auto resolution = text::parse_int(method_parameter(spec, "resolution"));
    const double R = resolution ? double(*resolution) : 0.0;
    const double pixels = 3.0 * R * R;
    e.method_bytes = pixels * (8.0 * threads + 16.0);
    return rows * (pixels * kSecondsPerHemicubePixel + n * kSecondsPerHemicubeElement);
  }
  if (spec.ff_method == "raycast" || spec.ff_method == "exact")
    e.method_bytes = kQuadratureBytesPerThread * threads;
  return rows * n * kSecondsPerPair;
}

}  // namespace

PreparationEstimate estimate_preparation(const ProblemSpec& spec, size_t elements, int threads) {
  PreparationEstimate e;
  const double n = double(elements);
  const double t = double(std::max(threads, 1));
  e.program_bytes = kProgramBytes + kBytesPerElement * n;
  e.matrix_bytes = 8.0 * n * n;
  if (spec.precision == Precision::kFloat && spec.row_mode == RowMode::kCached)
    e.float_bytes = 4.0 * n * n;
  if (spec.need_reference) e.reference_bytes = 8.0 * n * n;
  e.matrix_seconds = matrix_rows(spec, n, n, t, e);
  e.seconds = kStartSeconds + e.matrix_seconds +
              (spec.need_reference ? n * n * n / 3.0 * kSecondsPerLuFlop : 0.0);
  return e;
}

PreparationEstimate estimate_matrix_block(const ProblemSpec& spec, size_t elements,
                                          const MatrixBlock& block, int threads,
                                          const PairWorkSplit* work) {
  PreparationEstimate e;
  const double n = double(elements);
  e.program_bytes = kProgramBytes + kBytesPerElement * n;
  const double t = double(std::max(threads, 1));
  if (block.split == BlockSplit::kPairs && work && !work->unit.empty()) {
    // The facing pairs' entries (an estimate from the method's sample, never above the pairs').
    const double entries = std::min(2.0 * block.facing_pairs, block.entries());
    e.matrix_bytes = kPairBlockBytesPerEntry * entries;
    matrix_rows(spec, n, 0.0, t, e);  // the method's buffers
    e.matrix_seconds = double(block.work) * work->seconds_per_unit;
  } else if (block.split == BlockSplit::kPairs) {
    e.matrix_bytes = 16.0 * block.entries();
    e.matrix_seconds = matrix_rows(spec, n, block.entries() / n, t, e);
  } else {
    e.matrix_bytes = 8.0 * block.entries();
    e.matrix_seconds = matrix_rows(spec, n, double(block.end - block.first), t, e);
  }
  e.seconds = kStartSeconds + kStartSecondsPerElement * n + e.matrix_seconds;
  return e;
}

PreparationEstimate estimate_cached_preparation(const ProblemSpec& spec, size_t elements,
                                                double stored_bytes, int threads) {
  (void)threads;
  PreparationEstimate e;
  const double n = double(elements);
  e.program_bytes = kProgramBytes + kBytesPerElement * n;
  e.matrix_bytes = stored_bytes;
  if (spec.precision == Precision::kFloat && spec.row_mode == RowMode::kCached)
    e.float_bytes = stored_bytes / 2.0;
  const double channels = 3.0;  // the most a scene has (grey scenes: one)
  double reference_seconds = 0.0;
  if (spec.need_reference) {
    if (elements <= ReferenceOptions{}.dense_limit) {
      e.reference_bytes = 8.0 * n * n;
      reference_seconds = n * n * n / 3.0 * kSecondsPerLuFlop;
    } else {
      e.reference_bytes = kGmresVectors * 8.0 * n * channels;
      // An entry is stored in 8 bytes at least (its value; runs add up to 8 more).
      reference_seconds = kReferenceSecondsPerChannelEntry * channels * (stored_bytes / 8.0);
    }
  }
  e.seconds = kStartSeconds + kStartSecondsPerElement * n +
              stored_bytes / kBlockReadBytesPerSecond + reference_seconds;
  return e;
}

PreparationEstimate estimate_block_merge(const ProblemSpec& spec, size_t elements, int threads,
                                         const PairWorkSplit* work, double stored_bytes) {
  if (work && !work->unit.empty()) {
    const double n = double(elements);
    if (!(stored_bytes > 0)) {
      // Before the blocks exist: a share of the facing pairs' entries (at most n (n - 1)).
      const double facing = double(work->cumulative_facing.back()) * double(work->sample);
      stored_bytes =
          kStoredBytesPerEntry * std::min(2.0 * facing * kStoredShareOfFacing, n * (n - 1.0));
    }
    PreparationEstimate e = estimate_cached_preparation(spec, elements, stored_bytes, threads);
    // The merge's peak, when above the preparation's (matrix and float copy) after it.
    e.matrix_bytes =
        std::max(e.matrix_bytes, kMergeBytesPerStoredByte * stored_bytes - e.float_bytes);
    // Reading the blocks (stored as the merged matrix is) and writing the merged matrix.
    e.seconds += 2.0 * stored_bytes / kBlockReadBytesPerSecond;
    return e;
  }
  PreparationEstimate e = estimate_preparation(spec, elements, threads);
  e.seconds += e.matrix_bytes / kBlockReadBytesPerSecond - e.matrix_seconds;
  e.matrix_seconds = 0;
  e.method_bytes = 0;  // no rows computed
  return e;
}

}  // namespace radlab
