#include "formfactor/matrix/parallel_row.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <vector>

namespace radlab {

void row_in_parallel(const FormFactorMethod& method, size_t i, std::span<double> out,
                     RowCost& cost) {
  const size_t n = out.size();
  const size_t blocks = (n + kRowBlock - 1) / kRowBlock;
  // A row the method cannot split, or too short to pay for a task: on this thread.
  RowCost probe;
  if (blocks < 2 || !method.row_part(i, 0, std::min(n, kRowBlock), out, probe)) {
    method.row(i, out, cost);
    return;
  }
  // Each block's cost in its own slot, summed in block order afterwards.
  std::vector<RowCost> costs(blocks);
  costs[0] = probe;
  tbb::this_task_arena::isolate([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(1, blocks, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t b = r.begin(); b != r.end(); ++b) {
                          const size_t lo = b * kRowBlock;
                          method.row_part(i, lo, std::min(n, lo + kRowBlock), out, costs[b]);
                        }
                      });
  });
  for (const RowCost& c : costs) cost += c;
}

}  // namespace radlab
