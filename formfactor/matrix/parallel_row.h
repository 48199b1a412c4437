// One row of F computed on all the threads radlab may use (issue 13: an on-the-fly row of
// office3 took 651 ms on one core while the other idled).
//
// The receivers j are split into fixed blocks of kRowBlock elements, independent of the thread
// count, and each block is filled by the method's row_part(); every F_ij is computed by the same
// code from the same inputs (raycast's and exact's visibility samples are seeded per pair), so the
// row is bit-identical to row() whatever the thread count. The cost counters are integer sums,
// exact in any order. Methods that cannot split a row (the hemicube: one z-buffer per row) run
// row() on the calling thread.
//
// The work runs in an isolated task arena region: a thread waiting for the row's blocks never
// picks up an unrelated outer task (another row's computation), which would share its
// thread_local scratch buffers.
#pragma once

#include <cstddef>
#include <span>

#include "formfactor/form_factor_method.h"

namespace radlab {

// Receivers per parallel block: large enough that a block's pairs (~1-10 us each for raycast)
// dwarf the scheduling cost, small enough to balance a row of a few thousand elements.
inline constexpr size_t kRowBlock = 64;

// out (size n) = row i of `method`; adds the row's cost to `cost`.
void row_in_parallel(const FormFactorMethod& method, size_t i, std::span<double> out,
                     RowCost& cost);

}  // namespace radlab
