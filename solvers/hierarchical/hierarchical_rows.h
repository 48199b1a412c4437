// Row normalisation of hierarchical radiosity: what each leaf gathers, per unit radiosity of the
// scene, made the row sum of one quadrature rule at that leaf (and never above 1).
//
// Why: a leaf gathers through the links of every node on its path to the root, each link's
// factor averaged over that node (a 2 x 2 rule over the node, hierarchical_refine.h), not over
// the leaf. The link sum S_L = sum over those links of the factor is therefore not the leaf's
// own row sum: even with exact factors it scatters around it (by about the factors' variation
// over the receiving nodes), while its area-weighted mean is conserved. With reciprocal factors
// the gather operator is self-adjoint in the area inner product, so its spectral radius is at
// least the area-weighted mean of S_L (the Rayleigh quotient of a constant), strictly more when
// S_L spreads: on a closed box (mean 1) lambda > 1, so rho * lambda > 1 once rho > 1 / lambda
// and the Jacobi passes diverge (docs/stability.md measured it at rho >= 0.99).
//
// What: for every leaf L, T_L = sum over the same links of V_k times the form factor from L to
// the link's source by the 2 x 2 rule over L itself (the four children's centres, area
// weighted; Lambert's exact point-to-polygon value at each). All of L's links share the same
// four points and their sources are disjoint, so T_L is that rule's row sum: exactly 1 (to
// rounding) in an unoccluded closed box, below 1 wherever light escapes. The leaf then applies
// row_scale = min(T_L, 1) / S_L to everything it gathers; its row sum is min(T_L, 1) <= 1, so a
// pass with every rho < 1 contracts in the max norm and the furnace gives E / (1 - rho). Links
// at the leaf itself use the same rule for their factor, so they contribute equally to S_L and
// T_L: the correction comes only from the ancestors' links.
//
// The emitted light (issue 35.1): row_scale corrects the reflected light's row; applied to the
// emitters' light it broke their power balance (a 1 mm lamp in a closed room delivered 1.4% more
// than it sent: the scale of each leaf comes from its wall-to-wall links). So the emitted part is
// taken out of the scaled gather and received by the leaf's own rule instead, as a per-leaf offset
// (Hierarchy::row_offset; B = E + rho (row_scale * gathered + offset)): a link from an emitter
// smaller than the leaf by the source-side rule (V times the sum over the source's four child
// centres of their area times the point-to-polygon factor to the leaf, over A_L: exact over the
// leaf, so the leaves a point-like lamp reaches receive exactly its power, its points seeing a
// partition of the room), the other emitting links by the leaf's 2 x 2 value, scaled so the
// emitted row is min(T_L, 1) as before (a furnace's uniform E gives E / (1 - rho) exactly).
// The reflected light's transfer is not conservative by rows alone: the rows sum to min(T_L, 1)
// but the columns c_j (the power leaf j's light delivers, per unit) do not; RowStats reports
// their range and mean deviation (docs/solvers.md, "Emitted light").
//
// Column balance (rows=balanced): a second, source-side scale t_j on the reflected light each
// leaf sends (B - E, so the emitted light keeps its own rule), found with the row scales by
// alternating (Sinkhorn–Knopp) scaling until every leaf's column is its row target too: by
// reciprocity the power a leaf's light delivers is its own row sum. Then a closed scene passes
// on every unit of reflected power it receives. Links read S = E + t (B - E) (pulled) instead
// of B; B itself, what the leaves show, is unchanged in form.
//
// Clusters: a leaf's path runs on through its chart's clusters; a link from a cluster source is
// evaluated at the leaf's four points by the isotropic kernel (hierarchical_clusters.h), and its
// emitted light is received by that value, not as point-like. T_L is then that rule's row sum of
// the clustered operator, no longer exactly 1 in a closed box where cluster links remain. With
// the per-orientation push (Hierarchy::slots) a link at a cluster on the leaf's path counts in
// S_L by its factor times the leaf's slot share (what the push gives the leaf), and a cluster
// source's emission is read toward the link's receiver, as the gathers read it. The column sums
// reported (RowStats) follow the area-average push and pull even then.
//
// Cost: one 2 x 2 evaluation (4 point-to-polygon values, batched) per leaf and link on its
// path above it, and one more per (leaf, emitting link) whose source is smaller than the leaf; no
// rays (V is the link's). Left out: the leaf's own visibility (a link's V is
// its nodes' 16-ray fraction) and any correction of interior nodes (only leaves hold B).
#pragma once

#include <cstdint>
#include <vector>

#include "solvers/hierarchical/hierarchical_hierarchy.h"
#include "solvers/hierarchical/hierarchical_tree.h"

namespace radlab::hier {

struct RowStats {
  double max_link_sum = 0.0;    // largest S_L before normalisation
  double min_link_sum = 0.0;    // smallest S_L over leaves that gather anything
  double max_row = 0.0;         // largest row sum after: max over leaves of min(T_L, 1)
  size_t leaves_above_one = 0;  // leaves whose S_L exceeded 1
  double max_change = 0.0;      // largest |row_scale - 1|
  uint64_t evaluations = 0;     // (leaf, ancestor link) pairs evaluated by the 2 x 2 rule
  uint64_t nonfinite = 0;       // point values without a defined result (taken as 0)
  // The reflected light's column sums after normalisation (the power a leaf's light delivers,
  // per unit of it): their range and area-weighted mean |c - 1|.
  double min_column = 0.0, max_column = 0.0, mean_column_deviation = 0.0;
  // Column balance (balance = true): Sinkhorn rounds taken, and the largest relative distance of
  // a leaf's column from its target at the end.
  int balance_rounds = 0;
  double balance_residual = 0.0;
};

// Sets h.row_scale for every leaf (1 for interior nodes and leaves that gather nothing); with
// `balance`, also h.send_scale and h.S so that every leaf's column meets its row target too.
RowStats normalise_rows(Hierarchy& h, const std::vector<Chart>& charts, bool balance = false);

}  // namespace radlab::hier
