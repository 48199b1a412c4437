// `exact` form factors: unoccluded element-to-element form factors to ~1e-9 relative, for
// validation and for small scenes where nothing can occlude.
//
//   F_ij = (1/A_i) * integral over x in element i of F_{dx -> j} dA_x
//
// with Lambert's exact point-to-polygon formula (point_polygon.h) as the integrand and adaptive
// subdivision of the part of element i in front of j's plane (polygon_integral.h: 4 children,
// 3x3 Gauss rules, the worst cell first, until the estimated error of the whole pair is within
// `tolerance` relative). The integrand is analytic for separated pairs and has an integrable
// log-singular derivative along an edge two elements share; both converge
// (tests/formfactor/closed_forms_test.cpp: parallel and perpendicular unit squares within 1e-8).
// Separated pairs first try fixed Gauss rules of orders m and m - 1 (m from the Bernstein bound;
// the double-area rule of double_area.h where both elements face each other wholly, else
// Lambert's formula on a single-area rule) and keep order m when the two agree within
// `tolerance` (exact.cpp, unoccluded()). A pair the adaptive rule does not finish within a few
// thousand evaluations (near and touching pairs at tight tolerances) goes to the contour integral
// (contour_integral.h), whose cost grows with the logarithm of the tolerance. Each pair is
// integrated over its smaller element (the lower index on a tie) and the other entry follows by
// reciprocity, so the symmetric build (symmetric_build.h) and every row give the same bits.
//
// Visibility. The formula knows nothing of occluders, so the method is valid only when no pair
// can be occluded: the scene is a convex enclosure, or shaft culling (shaft.h) proves every
// facing pair's shaft empty. Otherwise it refuses (InputError, exit 3) and names a pair and a
// polygon that may block it — unless `visibility=rays`, which multiplies every pair that may be
// blocked by the raycast visibility fraction (`rays` Embree rays between jittered points, seeded
// by `seed`; V_ij = V_ji). The result is then exact only where nothing blocks; elsewhere its error
// is that of the visibility estimate (~1/sqrt(rays) per partly occluded pair), as for `raycast`.
//   `visibility=clip` instead computes occluded pairs deterministically: a pair whose shaft some
// polygon may reach integrates, at each quadrature point x of i, Lambert's formula over the part
// of j that x sees, j minus the shadows from x of the polygons in the shaft (visible_polygon.h).
// Pairs whose shaft is empty cost what they cost without clipping; fully hidden pairs end at the
// first 3x3 rules (every point sees nothing, so the estimated error is 0). The error is then the
// quadrature's alone: `tolerance` relative per pair, estimated by the same adaptive rule (the
// integrand is continuous; its derivative jumps where a shadow edge crosses an edge of j, which
// the rule refines like a shared edge). No seed.
//
//   Work cap (clip mode). Where the visible part changes abruptly the adaptive rule converges
// slowly: along a kink line (a shadow edge crossing an edge of j) its error falls as 4^-depth,
// so tolerance 1e-10 needs ~17 levels; along the line where an occluder stands on i (a box on a
// floor) the integrand jumps and the error falls only as 2^-depth. builtin:cornell at the
// default tolerance did not finish in 10 CPU minutes. So a clipped pair stops after
// `max_evaluations` integrand evaluations (or at max_depth) with its remaining estimated error
// (the adaptive rule's leaf estimates, polygon_integral.h), and whatever of that exceeds
// tolerance * F_ij is added to the stated error of rows i and j (largest_row_excess();
// diagnostics.cpp's stated_row_sum_error). The tolerance is then not what the row meets: the
// stated error says so. Cost: at most max_evaluations clipped evaluations per occluded pair.
// An occluder touching i's plane (standing on i) would leave a jump inside i: i is split along
// its plane into convex pieces first (split_on_contacts), so the jump lies on the pieces' edges
// and the rule converges there (docs/formfactors.md, "Work cap of clip mode").
//
// Left out: pairs facing away or coplanar (no work, pairs_culled); visibility rays wherever
// nothing can occlude (pairs_unoccluded).
//
// Parameters (their defaults are ExactOptions' own; `radlab solvers` prints them): tolerance
// (relative, per pair), max_depth (subdivision levels), visibility (refuse | rays | clip), rays
// (per pair that may be blocked; only with visibility=rays), seed (only with visibility=rays),
// max_evaluations (per occluded pair; only with visibility=clip).
#pragma once

#include <cmath>
#include <memory>
#include <mutex>
#include <unordered_set>

#include "formfactor/form_factor_method.h"
#include "formfactor/integrate/double_area.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/matrix/fixed_sum.h"
#include "formfactor/visibility/shaft.h"
#include "formfactor/visibility/visibility.h"
#include "formfactor/visibility/visible_polygon.h"

namespace radlab {

struct ExactOptions {
  double tolerance = 1e-10;  // relative error per pair; each factor 10 costs ~2-4x evaluations
  int max_depth = 16;        // subdivision levels of the adaptive rule; bounds the work per pair
  bool visibility_rays = false;  // false: refuse scenes that can occlude; true: multiply by V
  int rays = 64;                 // visibility rays per pair that may be blocked (rays mode)
  uint64_t seed = 0;             // jitter of the visibility points (rays mode)
  bool visibility_clip = false;  // true: clip P_j by the occluders' shadows (deterministic)
  // clip mode: integrand evaluations per occluded pair before the adaptive rule stops short of
  // the tolerance and states its remaining estimated error instead (see "Work cap" above)
  long long max_evaluations = 20000;

  static ExactOptions from(ParamBag& bag);
  void validate() const;
  std::string canonical() const;
};

class ExactFormFactors;
void save_row_excess(const ExactFormFactors& method, const std::string& matrix_file);
bool load_row_excess(const ExactFormFactors& method, const std::string& matrix_file, size_t n);

class ExactFormFactors final : public FormFactorMethod {
 public:
  // Throws InputError when the scene can occlude and visibility rays are off.
  ExactFormFactors(const Scene& scene, const Mesh& mesh, ExactOptions options);
  ~ExactFormFactors() override;
  std::string name() const override { return "exact"; }
  std::string parameters() const override { return options_.canonical(); }
  std::vector<std::string> left_out() const override;
  void row(size_t i, std::span<double> out, RowCost& cost) const override;
  bool row_part(size_t i, size_t lo, size_t hi, std::span<double> out,
                RowCost& cost) const override;

  // Stated errors (form_factor_method.h): a row sum within the tolerance, float storage, what
  // pairs stopped short of the tolerance left (largest_row_excess) and, with visibility=rays,
  // the visibility allowance; reciprocity to rounding (each pair is one integral, the other
  // entry its reciprocal).
  double stated_row_sum_error(std::string* basis = nullptr) const override;
  std::optional<double> stated_reciprocity_error() const override;
  // The ".excess" side file (save_/load_row_excess below): a cached matrix without it is rebuilt.
  void save_side_files(const std::string& matrix_file) const override {
    if (records_row_excess()) save_row_excess(*this, matrix_file);
  }
  bool load_side_files(const std::string& matrix_file, size_t n) const override {
    return !records_row_excess() || load_row_excess(*this, matrix_file, n);
  }
  // Symmetric builds: upper_row (below) and the other side by reciprocity.
  bool integrates_pairs_once() const override { return true; }
  void orient_row(size_t i, std::span<double> row) const override;
  // Blocks of pairs (form_factor_method.h): upper_row's integrals, each entry oriented as
  // orient_row orients it. A block's state is its pairs' row excesses (the count of pairs stopped
  // short, then n sums in fixed point, as the method keeps them: fixed_sum.h), added up by the
  // merge: the same bits as a one-process build's, whose threads add in any order.
  bool builds_in_pair_blocks() const override { return true; }
  void pair_entries(size_t i, std::span<double> upper, std::span<double> lower,
                    RowCost& cost) const override;
  size_t pair_block_state_bytes(size_t n) const override { return (n + 1) * sizeof(FixedSum); }
  std::vector<char> pair_block_state() const override;
  bool restore_pair_block_states(const std::vector<std::vector<char>>& states) const override;

  // F_ij, integrated over the smaller element of the pair (the lower index on equal areas; in
  // clip mode sometimes the other one, see pair_integral) and turned around by reciprocity on
  // the other side: pair(i, j) A_i == pair(j, i) A_j to rounding, and each is within
  // `tolerance` relative of the exact value. row(), row_part() and build_matrix_symmetric() all
  // give these bits (the symmetric build integrates each pair once).
  double pair(size_t i, size_t j, RowCost& cost) const;
  // F_ij integrated over element i whatever the areas (the one-way integral pair() orients).
  // In clip mode, with `may_turn`, an occluded pair whose nearest occluder is clearly nearer i
  // than j, and whose j is at most twice i's area, is integrated over j instead and turned
  // around by reciprocity (the shadows then move slowly across the integrated element: far
  // fewer kinks to resolve; docs/formfactors.md, "Which side to integrate"), and a zero that no
  // single occluder proves is checked from the other side. Without it, always over i and
  // nothing else (two independent integrations of a pair, for tests).
  double pair_integral(size_t i, size_t j, RowCost& cost, bool may_turn = true) const;
  // For every j in (i, n): out[j] = the pair's integral over its integrated side a
  // (integrates_from), pair_integral(a, b), the same bits and costs. The pairs of a batch take
  // their set-up (heights, gap, the double-area order: square roots and divisions in a chain)
  // one after the other before any is integrated, so the chains overlap instead of stalling
  // each pair (build_matrix_symmetric's rows).
  void upper_row(size_t i, std::span<double> out, RowCost& cost) const override;
  // Whether pair(i, j) integrates over i (true) or over j and scales by A_j / A_i (false).
  static bool integrates_from(const Mesh& mesh, size_t i, size_t j) {
    return mesh.area[i] < mesh.area[j] || (mesh.area[i] == mesh.area[j] && i < j);
  }
  // The entry of the element not integrated over: F_ba = F_ab A_a / A_b.
  static double reciprocal(double f_ab, double area_a, double area_b) {
    return f_ab * (area_a / area_b);
  }
  // The largest, over the rows, of the row's stated error beyond `tolerance`: the sum over its
  // pairs stopped by the work cap (clip mode: max_evaluations; unoccluded pairs: 2e7
  // evaluations, exact.cpp) or by max_depth of their remaining estimated error
  // less tolerance * F (0 when every pair reached the tolerance). Covers the pairs integrated so
  // far in this process; thread-safe.
  double largest_row_excess() const;
  double row_excess(size_t i) const;
  // How many pairs so far stopped short of the tolerance (each unordered pair once).
  size_t pairs_capped() const;
  // Whether the method records row excesses (always, since unoccluded pairs have a work cap
  // too): a matrix loaded from the cache then needs them from the file kept beside it
  // (save_/load_row_excess).
  bool records_row_excess() const { return !row_excess_.empty(); }
  std::vector<double> row_excesses() const;
  void set_row_excesses(std::vector<double> excess, size_t pairs) const;

 private:
  // The highest fixed Gauss order tried on separated unoccluded pairs (then adaptive).
  static constexpr int kMaxFixedOrder = 16;
  const Scene& scene_;
  const Mesh& mesh_;
  ExactOptions options_;
  double plane_epsilon_ = 0.0;
  bool nothing_occludes_ = false;  // convex enclosure, or every facing pair's shaft is empty
  std::unique_ptr<Visibility> visibility_;  // rays mode only
  std::unique_ptr<ShaftCuller> shafts_;     // clip mode (unless nothing can occlude)
  std::vector<Vec3> occluder_normal_;       // clip mode: unit normal of every input polygon
  std::vector<double> radius_;              // each element's largest centroid-corner distance
  FixedOrderRule order_rule_;               // Bernstein-bound Gauss order for separated pairs
  ElementRules element_rules_;              // Gauss rules of every element (double-area pairs)
  // Every element's corners back to back (at mesh_.first_vertex): a pair whose elements need no
  // clipping reads them in place instead of copying them (Mesh::corners) for every pair.
  std::vector<Vec3> corner_;
  std::span<const Vec3> corners(size_t e) const {
    return {corner_.data() + mesh_.first_vertex[e],
            mesh_.first_vertex[e + 1] - mesh_.first_vertex[e]};
  }
  // The heights of one element's corners above the other's plane, from one pass over them: what
  // pair_faces, clip_to_front and the Bernstein order each computed again from the same dots.
  struct Heights {
    double low = 1e300;   // the least height
    double high = 0.0;    // the greatest, or 0 when every corner lies below
    bool front = false;   // some corner more than plane_epsilon_ in front
    bool behind = false;  // some corner more than plane_epsilon_ behind
  };
  Heights heights(std::span<const Vec3> corners, const Vec3& point, const Vec3& normal) const;
  // The double-area rule's order for the pair (i, j), both wholly in front of each other's
  // planes and `gap` apart: the Bernstein bound for the larger element and the smaller of the
  // two height scales (0 when no fixed order suffices).
  int double_area_order(size_t i, size_t j, double gap, const Heights& i_heights,
                        const Heights& j_heights) const;
  // The rules of orders m and m - 1 (at least 2 and 1) on both elements.
  void double_area_rules(size_t i, size_t j, int m, DoubleAreaRules& out) const;
  // Whether the two rules agree within `tolerance` (the pair then takes f.high).
  bool agree(const DoubleAreaPair& f) const {
    return std::abs(f.high - f.low) <= options_.tolerance * std::abs(f.high);
  }
  // Counted as the points of i at which an inner sum over j stands in for F_{dx->j} (what a
  // kernel evaluation is elsewhere), not the m^4 cheap terms.
  static uint64_t double_area_evaluations(const DoubleAreaRules& rules) {
    return uint64_t(rules.a_high.count + rules.a_low.count);
  }
  // The smaller of the two height scales of that bound (i_high, j_high: the highest corners),
  // and in `both` the larger element's diameter.
  double double_area_scale(size_t i, size_t j, double i_high, double j_high, double& both) const;
  // i_heights: `from`'s above j's plane; j_heights: `to`'s above i's plane.
  double unoccluded(size_t i, size_t j, std::span<const Vec3> from, std::span<const Vec3> to,
                    double kept, const Heights& i_heights, const Heights& j_heights,
                    RowCost& cost) const;
  // Clip mode: the shaft's candidates for (i, j) that no plane separates from `from` (i's part
  // in front of j's plane) and `to`.
  void pair_occluders(size_t i, size_t j, std::span<const Vec3> from, std::span<const Vec3> to,
                      std::vector<Occluder>& occluders) const;
  // Whether the nearest occluder is clearly nearer i's centroid than j's (then the pair is
  // integrated over j: smaller, slower shadows).
  bool occluders_nearer(size_t i, size_t j, std::span<const Occluder> occluders) const;
  // Clip mode: whether any point of a 6 x 6 Gauss rule over `from` sees part of `to` past the
  // occluders (a probe before integrating a pair the other side found 0).
  bool any_visible(size_t i, size_t j, std::span<const Vec3> from, std::span<const Vec3> to,
                   std::span<const Occluder> occluders, RowCost& cost) const;
  // Clip mode: F_ij over `from` (i's part in front of j's plane, `kept` of its area) past the
  // non-empty `occluders`, with the corner test, the contact splits and the work cap.
  // `proven_hidden` (if given) is set when the corner test proved the pair 0.
  double occluded(size_t i, size_t j, std::span<const Vec3> from, std::span<const Vec3> to,
                  double kept, std::span<const Occluder> occluders, RowCost& cost,
                  bool* proven_hidden = nullptr) const;
  double clipped_pair(size_t i, size_t j, std::span<const Vec3> from, std::span<const Vec3> to,
                      std::span<const Occluder> occluders, double floor, long long max_evaluations,
                      RowCost& cost, double* error) const;
  void split_on_contacts(size_t i, std::span<const Vec3> from, std::span<const Occluder> occluders,
                         std::vector<std::vector<Vec3>>& pieces, std::vector<double>& shares) const;
  // Records pair (i, j)'s error beyond tolerance (absolute, in F_ij; integrated over i) in rows i
  // and j, once per unordered pair however often the pair is recomputed.
  void record_excess(size_t i, size_t j, double excess) const;
  mutable std::mutex excess_mutex_;
  mutable std::unordered_set<uint64_t> capped_pairs_;  // i * n + j of the pairs recorded
  mutable std::vector<FixedSum> row_excess_;           // per row, F units (fixed_sum.h)
  mutable size_t loaded_pairs_ = 0;                    // pairs_capped of a loaded matrix
};

// The row excesses beside a cached matrix file (`matrix_file` + ".excess": the count of pairs
// stopped short, then n doubles, as a matrix side file: bound to the matrix file's header and key
// under a checksum, write_matrix_side_file in formfactor/matrix/matrix_cache.h). load_ returns
// false (and changes nothing) when the file is missing, of the wrong size, fails its checksum or
// its matrix binding, or holds a negative or non-finite value (a file that is there but refused
// is named in a warning): the caller must then not use the cached matrix (its stated error
// would lack the pairs stopped short), but rebuild it.
void save_row_excess(const ExactFormFactors& method, const std::string& matrix_file);
bool load_row_excess(const ExactFormFactors& method, const std::string& matrix_file, size_t n);

}  // namespace radlab
