// Patch-to-element rows computed by the form-factor method, and the two-level system's element
// rows derived from them: Cohen, Chen, Wallace & Greenberg 1988 §3.4 and the §4 pseudo-code
// ("for each patch: position hemi-cube on patch, project elements onto it, compute F_pe").
//
// Rules (`[patches] rows`, --patch-rows):
//   centre  the method's row at the patch's centre (FormFactorMethod::row_at_point: the
//           area-weighted centroid of its elements; for a one-element patch exactly that
//           element's centroid and frame, so the row is the element's own row bit for bit). The
//           paper's rule (one hemicube per patch); only methods whose rows are taken at a point
//           (FormFactorMethodInfo::rows_at_points: hemicube). Cost: P rows at a point (hemicubes:
//           each O(n) set-up + the pixels covered).
//   mean    the area-weighted mean of the patch's elements' rows, P_pe = sum_{i in p} (A_i/A_p)
//           F_ie: the patch-to-element form factor integrated over the patch (any method). Each
//           element row is computed, added and dropped; cost n element rows (as a dense build),
//           memory still O(P n). Better defined (it is the exact patch-to-element factor of the
//           method's element rows, where the centre rule samples one point of the patch), but
//           not the paper's cost model.
// Either way nothing of size n x n is held.
//
// The two-level system (docs/solvers.md, "Two levels") is defined by P alone:
//
//   B_e = E_e + rho_e sum_j K_ej B_j,   K_ej = F_{e,p(j)} A_j / A_p(j),   F_{e,p} = P_pe A_p / A_e
//
// (reciprocity gives the element-to-patch factor from the patch's row). A patch shooting P_p and
// an element gathering K_e are exact transposes of each other, so every solver solves the same
// system. TwoLevelRows serves K's rows on demand (O(n) each: column e of P, then one product per
// element), as a FormFactorMethod for System's on-the-fly path.
// Left out: patch rows for raycast/exact by a single point (both integrate over the source
// element; their patch row is `mean`); caching patch rows on disk (P hemicubes are seconds).
#pragma once

#include <functional>
#include <string>

#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"
#include "solvers/two_level/patches.h"

namespace radlab {

enum class PatchRowRule { kCentre, kMean };

// "centre" | "mean" (UsageError otherwise) and back.
PatchRowRule patch_row_rule(const std::string& name);
std::string patch_row_rule_name(PatchRowRule rule);

struct PatchRowReport {
  RowCost cost;
  double seconds = 0.0;
  size_t method_rows = 0;       // hemicubes (centre: one per patch) or element rows (mean) computed
  double max_row_sum = 0.0;     // max_p sum_e P_pe (<= 1 + the method's error: light is conserved)
  double max_gather_sum = 0.0;  // max_e sum_p F_{e,p}: reciprocity can push it above 1 (docs)
  std::string summary() const;
};

// The P x n patch rows of `patches` by `rule` (rows in parallel; `precision` for storage, sums in
// double). UsageError for centre with a method whose rows are not taken at a point.
RowMatrix compute_patch_rows(const FormFactorMethod& method, const Mesh& mesh,
                             const Patches& patches, PatchRowRule rule, Precision precision,
                             PatchRowReport& report,
                             const std::function<void(size_t done, size_t total)>& progress = {});

// K's rows from the patch rows (not owned; both must outlive it): row(e) fills
// K_ej = (P_{p(j),e} A_p(j) / A_e) (A_j / A_p(j)). No rays; charged as kernel evaluations of P.
class TwoLevelRows final : public FormFactorMethod {
 public:
  TwoLevelRows(const Mesh& mesh, const Patches& patches, const RowMatrix& rows);
  std::string name() const override { return "two-level"; }
  std::string parameters() const override { return ""; }
  void row(size_t e, std::span<double> out, RowCost& cost) const override;
  // K's rows are derived, not computed by a method: their sums are the element-to-patch sums
  // reciprocity gives (PatchRowReport::max_gather_sum), which a patch's aliasing on a small
  // element can push above 1. What is stated is that excess, measured (O(P n)); the patch rows
  // themselves are held to the method's stated error (experiments/problem/two_level_problem.cpp).
  double stated_row_sum_error(std::string* basis = nullptr) const override;

 private:
  const Mesh& mesh_;
  const Patches& patches_;
  const RowMatrix& rows_;
};

// The rows of the two-level system whose receivers are coarser: blocks of elements (block_of[e]
// per element; each block inside one polygon), as adaptive-shooting's final mesh. Block b's row
// is the sum of its elements' (what a hemicube sees of their union), spread back over them by
// area: out_pe = (A_e / A_b) sum_{e' in b} rows_pe'. The two-level system of these rows on the
// evaluation mesh is the blocks' system with each element holding its block's value: K's row e
// becomes the area-weighted mean of the rows of e's block, so B_e is constant over a block
// where rho and E are (docs/solvers.md, "Adaptive subdivision").
RowMatrix block_rows(const RowMatrix& rows, std::span<const double> area,
                     std::span<const uint32_t> block_of);

// The dense n x n K of the rows above, for tests and small checks only (O(n^2) memory).
FormFactorMatrix dense_two_level_matrix(const Mesh& mesh, const Patches& patches,
                                        const RowMatrix& rows, Precision precision);

}  // namespace radlab
