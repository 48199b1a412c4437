#include "experiments/problem/preparation_estimate.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "core/text.h"
#include "formfactor/registry.h"

namespace radlab {
namespace {

// Measured on this machine (docs/reliability.md, scripts/measure_estimates.py), rounded up: the
// program with a small scene peaks at ~22 MB; a mesh element with its vertices, Embree's BVH and
// the per-element arrays of the matrix build and the system costs well under 4 kB.
constexpr double kProgramBytes = 64e6;
constexpr double kBytesPerElement = 4e3;
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
                                          const MatrixBlock& block, int threads) {
  PreparationEstimate e;
  const double n = double(elements);
  e.program_bytes = kProgramBytes + kBytesPerElement * n;
  const double t = double(std::max(threads, 1));
  if (block.split == BlockSplit::kPairs) {
    e.matrix_bytes = 16.0 * block.entries();
    e.matrix_seconds = matrix_rows(spec, n, block.entries() / n, t, e);
  } else {
    e.matrix_bytes = 8.0 * block.entries();
    e.matrix_seconds = matrix_rows(spec, n, double(block.end - block.first), t, e);
  }
  e.seconds = kStartSeconds + e.matrix_seconds;
  return e;
}

PreparationEstimate estimate_block_merge(const ProblemSpec& spec, size_t elements, int threads) {
  PreparationEstimate e = estimate_preparation(spec, elements, threads);
  e.seconds += e.matrix_bytes / kBlockReadBytesPerSecond - e.matrix_seconds;
  e.matrix_seconds = 0;
  e.method_bytes = 0;  // no rows computed
  return e;
}

}  // namespace radlab
