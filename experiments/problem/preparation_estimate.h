// What preparing a problem (prepare_problem) holds at its peak, and roughly how long it takes,
// estimated from its element count before anything n x n is allocated. The `memory_gb` limit is
// checked against the whole of it (it was the dense matrix alone: a process of 228 MB passed a
// 97 MB limit), and `radlab prepare --plan` gives it to the workflow's scheduler requests (it
// ignored the hemicube's resolution: planned 0.034 s and 257 MB, took 17-49 s and 408 MB at R
// 2048). Upper-bound-minded; docs/reliability.md gives the measured ratios
// (scripts/measure_estimates.py).
#pragma once

#include <cstddef>
#include <string>

#include "experiments/problem/problem.h"
#include "formfactor/matrix/matrix_blocks.h"

namespace radlab {

struct PreparationEstimate {
  double program_bytes = 0;    // radlab, the scene, the mesh and Embree's BVH
  double matrix_bytes = 0;     // the method's matrix in double, bounded by its dense size 8n^2
  double float_bytes = 0;      // its float rounding held beside it (float storage): 4n^2
  double reference_bytes = 0;  // the certified reference's dense LU, factorised in place: 8n^2
  double method_bytes = 0;     // the method's working memory (hemicube: buffers and weights)
  double seconds = 0;          // starting, building the matrix and the reference (wall clock)
  double matrix_seconds = 0;   // of which building the matrix (its rows)

  double total_bytes() const {
    return program_bytes + matrix_bytes + float_bytes + reference_bytes + method_bytes;
  }
  // "matrix 66 MB + float copy 33 MB + reference LU 66 MB + hemicube buffers 403 MB + ...".
  std::string describe() const;
};

// For a dense preparation of `spec` on `elements` elements (the matrix; the reference when
// spec.need_reference). The method's parameters are spec.ff_set over the method's defaults.
PreparationEstimate estimate_preparation(const ProblemSpec& spec, size_t elements, int threads);

// Blocked builds (formfactor/matrix/matrix_blocks.h). A block of rows: its rows in double (8n
// bytes a row), computed at the dense rate. A block of pairs cut by the method's estimated work
// (`work` with a unit, FormFactorMethod::pair_work): its seconds are its share of the work at
// the method's calibrated rate (CPU seconds: the wall time on one thread, a bound on more), its
// memory that of its facing pairs' entries (both entries each: the most that can be non-zero)
// held in its two passes (kPairBlockBytesPerEntry, fitted to measured peaks). Without an estimate:
// both entries of every pair at 16 bytes (the dense bound) and the dense rate. Each holds the
// method's working memory and the program; a process start grows with the scene (loading,
// meshing, the BVH, the work estimate itself).
PreparationEstimate estimate_matrix_block(const ProblemSpec& spec, size_t elements,
                                          const MatrixBlock& block, int threads,
                                          const PairWorkSplit* work = nullptr);
// The merge and the preparation after it (the checks, the certified reference): with the
// method's estimate, the peak of the merge (every entry gathered and assembled, each block read
// in turn) or of the preparation that loads the merged matrix (estimate_cached_preparation),
// for `stored_bytes` of blocks (their files' sizes, once they exist: the merge's own check) or,
// in the plan, a share of the facing pairs' entries; the blocks read at 100 MB/s. Without an
// estimate, everything estimate_preparation holds, the blocks read instead of the matrix
// computed.
PreparationEstimate estimate_block_merge(const ProblemSpec& spec, size_t elements, int threads,
                                         const PairWorkSplit* work = nullptr,
                                         double stored_bytes = 0.0);
// A preparation whose matrix the cache holds, stored sparse in `stored_bytes` (its payload): the
// matrix loaded in double (its stored size), its float rounding (half that, float storage), the
// certified reference (dense LU, 8n^2, up to ReferenceOptions::dense_limit elements; above, the
// GMRES vectors, and products of the stored entries); the program. What the memory_gb limit
// checks when the matrix is cached, and what a merge's preparation is estimated by.
PreparationEstimate estimate_cached_preparation(const ProblemSpec& spec, size_t elements,
                                                double stored_bytes, int threads);

// The threads radlab's parallel loops use (--threads, else every core).
int preparation_threads();

}  // namespace radlab
