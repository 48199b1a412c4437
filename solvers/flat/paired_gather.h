// Gathers read two rows a pass where they can: a solver that gathers a known sequence of rows
// from one vector that does not change in between (Jacobi's sweep from the previous sweep's B,
// an interleaved gathering session from its snapshot) asks for row r and names the row it will
// gather next. On a dense matrix both are gathered in one pass (kernels::gather_pair: the vector
// is read once for both, the same bits as two gathers) and the second sum is kept for the next
// call; each row is charged to the System at the call that uses it, so the work columns still
// count one row a step. Elsewhere (sparse, on-the-fly or two-level rows) rows go one at a time.
#pragma once

#include <algorithm>
#include <cstddef>
#include <optional>

#include "core/radiosity.h"
#include "solvers/kernels/kernels.h"
#include "solvers/system.h"

namespace radlab {

class PairedGather {
 public:
  // Forgets a kept sum (at init, or when the vector gathered from changes).
  void reset() { kept_row_.reset(); }

  // out[c] = sum_j F_rj x_cj. With `next`, the row the caller will gather next from the same x,
  // and both rows dense, gathers that row too in the same pass and keeps its sum.
  void gather(const System& system, size_t r, std::optional<size_t> next, const Radiosity& x,
              double* out) {
    if (kept_row_ == r) {
      std::copy(kept_sum_, kept_sum_ + x.channels(), out);
      system.count_row();
      kept_row_.reset();
      return;
    }
    kept_row_.reset();
    if (next && system.with_dense_rows(
                    r, *next,
                    [&](const auto* F, const auto* F_next) {
                      kernels::gather_pair(F, F_next, x, out, kept_sum_);
                    },
                    /*count_k=*/false)) {
      kept_row_ = *next;
      return;
    }
    system.with_compact_row(r, [&](const auto& F) { kernels::gather(F, x, out); });
  }

 private:
  std::optional<size_t> kept_row_;  // the row whose sum kept_sum_ holds
  double kept_sum_[3] = {0.0, 0.0, 0.0};
};

}  // namespace radlab
