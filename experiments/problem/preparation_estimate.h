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

// Blocked builds (formfactor/matrix/matrix_blocks.h), by the same rates: one block (a block of
// rows held in double, 8n bytes a row at most; a block of pairs, both entries of each pair held
// twice in double while its rows are assembled, 16 bytes an entry at most, and computed at the
// dense rate per entry; the method's working memory; the program), and the merge (everything
// estimate_preparation holds, the blocks read at 100 MB/s instead of the matrix computed, then
// the reference).
PreparationEstimate estimate_matrix_block(const ProblemSpec& spec, size_t elements,
                                          const MatrixBlock& block, int threads);
PreparationEstimate estimate_block_merge(const ProblemSpec& spec, size_t elements, int threads);

// The threads radlab's parallel loops use (--threads, else every core).
int preparation_threads();

}  // namespace radlab
