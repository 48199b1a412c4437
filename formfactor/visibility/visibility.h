// The visibility fraction V_ij of a pair of elements, shared by `raycast` and `exact`:
//
//   V_ij = 1                        the scene is a convex enclosure, or the pair's shaft holds no
//                                   polygon that could block it (shaft.h): no rays;
//   V_ij = kernel-weighted share     otherwise: `rays` Embree occlusion rays between stratified,
//          of unblocked rays         jittered points on the part of i in front of j's plane and
//                                   the part of j in front of i's (the region the unoccluded
//                                   integral covers: clip_to_front, polygon_integral.h), paired
//                                   by a random permutation, each weighted by the form-factor
//                                   kernel cos cos / r^2 of its two ends (an equal-weight share
//                                   overestimates F when the near, heavy part of a large element
//                                   is the part that is hidden: docs/scenes.md); hits on i's and
//                                   j's own polygons are ignored (a segment meets them only at its
//                                   ends: such hits are rounding on grazing rays; the Embree filter
//                                   that drops them is attached only to pairs where they can
//                                   occur). Each segment skips a piece at each end (where it
//                                   would meet its own planes by rounding); for the segments
//                                   nothing blocked those pieces are traced again, ignoring only
//                                   hits in the end's plane, so a wall the end touches blocks
//                                   (trace_skipped_ends) — only the pieces another polygon
//                                   comes near: a grid per element over its plane says which
//                                   (compute_end_neighbours; the same V, fewer rays).
//
// Close pairs (the larger element's radius above a quarter of the centroids' distance; raycast
// only) draw each ray from a point of the smaller element to a point of the other drawn uniformly
// in solid angle (trace_close, 16 rays at once: sample_solid_angles), weighted Omega cos: bounded
// weights where uniform points on a huge element near a small one carry weights spanning orders of
// magnitude. Every traced pair also gets the standard error of its V (ratio_standard_error in
// visibility.cpp).
//
// The points depend only on (seed, min(i,j), max(i,j)) — each element is clipped by the other's
// plane whichever row asks — and the shaft decision only on the unordered pair, so V_ij = V_ji
// exactly.
#pragma once

#include <atomic>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <memory>
#include <string>
#include <vector>

#include "formfactor/form_factor_method.h"
#include "formfactor/visibility/embree_scene.h"
#include "formfactor/visibility/shaft.h"

namespace radlab {

class Visibility {
 public:
  // `shaft_culling` false traces every pair that is not in a convex enclosure (for comparisons).
  // `max_rays` > rays: partly occluded pairs with large form factors get up to that many
  // (rays_for in visibility.cpp); rays = max_rays: every pair gets `rays`.
  // `importance_close_pairs`: close pairs' rays drawn in solid angle (trace_close; raycast). Off,
  // every pair samples both elements uniformly in area, as exact's visibility=rays does: its
  // stated error is still the empirical allowance measured with that sampler.
  Visibility(const Scene& scene, const Mesh& mesh, int rays, uint64_t seed, bool shaft_culling,
             int max_rays = 0, bool importance_close_pairs = false);
  ~Visibility();

  // V_ij in [0,1]; counts the pair in cost.pairs_unoccluded or cost.pairs_traced (and its rays).
  // `sigma`, if given, receives the estimate's standard error (0 when no rays were needed;
  // ratio_standard_error in visibility.cpp), the same for V_ji. Thread-safe.
  double fraction(size_t i, size_t j, RowCost& cost, double* sigma = nullptr) const;

  // The rays fraction() casts for the pair when it needs rays (rays_for in visibility.cpp; from
  // the areas and the centroids' distance alone): also the raycast's estimate of a pair's work.
  int rays_for(size_t i, size_t j) const;
  // True when the pair needs rays (some polygon may block it); does no ray casting.
  bool needs_rays(size_t i, size_t j) const;
  // A polygon that may block the pair, or -1 (for messages).
  int64_t possible_blocker(size_t i, size_t j) const;

  bool convex_enclosure() const { return convex_enclosure_; }
  bool casts_rays() const { return !convex_enclosure_; }
  std::vector<std::string> left_out() const;

  // Whether the skipped ends' pieces that no other polygon comes near are left untraced (the
  // default; compute_end_neighbours). Off, every piece is traced again: V must not change (for
  // tests and measurement).
  void set_end_prefilter(bool on) { end_prefilter_ = on; }
  // Rebuilds the prefilter keeping neighbour lists only for elements with at most
  // `max_neighbours` (tests: 0 leaves every element its grid alone, as the memory budget does
  // where it runs out).
  void limit_end_lists(size_t max_neighbours) {
    max_end_neighbours_ = max_neighbours;
    if (embree_) compute_end_neighbours();
  }
  // Pieces traced again and pieces the prefilter proved clear, over all threads (measurement).
  uint64_t end_pieces_traced() const { return end_pieces_traced_.load(); }
  uint64_t end_pieces_cleared() const { return end_pieces_cleared_.load(); }
  // The prefilter's memory: grids, neighbours and their lists (measurement).
  size_t end_prefilter_bytes() const {
    return end_reach_.size() * sizeof(EndReach) + end_rows_.size() * sizeof(uint64_t) +
           end_neighbours_first_.size() * sizeof(uint32_t) +
           end_neighbours_.size() * sizeof(Neighbour) +
           (end_block_first_.size() + end_block_neighbours_.size()) * sizeof(uint32_t);
  }

  // Which traced pairs get the Embree filter that drops hits on i's and j's own polygons:
  // automatic (the default) only pairs where such a hit can occur; always every pair (V must not
  // change: for tests and measurement); never none (for tests: shows the hits it removes).
  enum class OwnPolygonFilter { automatic, always, never };
  void set_own_polygon_filter(OwnPolygonFilter mode) { own_polygon_filter_ = mode; }
  // How many of the pair's two polygons get that filter (0 when the pair casts no rays).
  int own_polygons_filtered(size_t i, size_t j) const;

  // While on, V of every pair is kept once known, so the pair's other row (V_ji = V_ij, the same
  // rays) reuses it without a shaft test or a ray, and counts the pair as the first row did: for
  // a build of every row (build_matrix), which then casts each pair's rays once. n(n-1) bytes.
  // Not thread-safe itself; fraction() stays thread-safe while it is on. Values are unchanged.
  void remember_pairs(bool on) const;

  // The standard error both rows of a pair get (fraction's `sigma`), held in the memo's 16 bits:
  // rounded up to steps of 2^-16, with code 65535 standing for 1 (the bound; also what NaN
  // gives: nothing known). The first row gets sigma_of_code(sigma_code(s)) too, not s rounded
  // on its own, so the two rows, one process or blocks, any thread order, see the same bits.
  static uint16_t sigma_code(double sigma);
  static double sigma_of_code(uint16_t code) {
    return code == kSigmaOne ? 1.0 : double(code) / kSigmaSteps;
  }

 private:
  // V in steps of 1/kSteps from R rays; its standard error in `sigma`.
  int trace(size_t i, size_t j, int R, RowCost& cost, double& sigma) const;
  void compute_own_polygon_margins();
  bool leaves_own_polygon(size_t from, double height) const;
  // The parts of lo and hi the rays join (each clipped to the other's front), with the least
  // height of each above the other's plane.
  struct FacingParts {
    std::vector<Vec3> lo, hi;
    double lo_height = 0.0, hi_height = 0.0;
  };
  bool facing_parts(size_t lo, size_t hi, FacingParts& parts) const;
  // Whether the pair is close compared with its larger element, so that the kernel varies by
  // more than ~3x over it and its rays are importance-sampled (trace_close).
  bool close_pair(size_t lo, size_t hi) const;
  int trace_close(size_t lo, size_t hi, const FacingParts& parts, int R, uint32_t skip_lo,
                  uint32_t skip_hi, double& sigma) const;
  uint32_t own_polygon_to_skip(size_t own, double height) const;
  void trace_skipped_ends(const SegmentPacket& segments, bool* blocked, size_t from,
                          size_t to) const;
  void compute_end_neighbours();
  // Its steps, per element e: e's frame and region (end_region, which also returns the region's
  // axis-aligned box), the elements of other polygons whose boxes reach into it
  // (end_candidates), the cells a candidate marks (mark_end_cells: returns the blocks it marked
  // in), and the lists e keeps within the budget (keep_end_lists).
  struct EndReach;
  struct Neighbour;
  EndReach end_region(size_t e, double reach, double margin, Box& region) const;
  void end_candidates(size_t e, const Box& region, const std::vector<Box>& boxes, double margin,
                      std::vector<Neighbour>& candidates) const;
  uint64_t mark_end_cells(const EndReach& r, const Neighbour& g, double reach);
  void keep_end_lists(size_t e, std::vector<uint64_t>& block_masks, size_t budget,
                      size_t& list_bytes);
  static constexpr uint8_t kPieceClear = 0, kPieceMarked = 1, kPieceTraced = 2;
  void classify_pieces(const SegmentPacket& segments, size_t end, bool at_origin, uint8_t* state,
                       uint32_t* block) const;
  bool piece_meets_a_neighbour(const SegmentPacket& segments, int lane, float t0, float t1,
                               uint32_t block) const;

  const Mesh& mesh_;
  bool importance_close_pairs_ = false;
  int rays_;
  int max_rays_ = 0;
  uint64_t seed_;
  double plane_epsilon_ = 0.0;
  bool convex_enclosure_ = false;
  std::unique_ptr<ShaftCuller> shafts_;  // null in a convex enclosure or without shaft culling
  std::unique_ptr<EmbreeScene> embree_;  // null in a convex enclosure
  std::vector<double> off_plane_;        // per element: its polygon's distance from its plane
  std::vector<double> radius_;           // per element: largest centroid-to-corner distance
  double float_error_ = 0.0;             // rounding of coordinates to Embree's floats
  OwnPolygonFilter own_polygon_filter_ = OwnPolygonFilter::automatic;
  // compute_end_neighbours: per element e, the elements of other polygons that reach within
  // the skipped-end pieces' reach of e, each as a box and a slab (|normal . x - offset| <=
  // thickness), listed from end_neighbours_first_[e] to end_neighbours_first_[e + 1]; and a
  // grid of kEndSide x kEndSide cells over e's plane (u along `across`, v along `along`, h along
  // `normal`, from `origin`), lo and hi bounding where e's pieces lie, whose rows (end_rows_
  // from first_row, bit u) mark the cells a neighbour meets.
  static constexpr int kEndSide = 64;
  size_t max_end_neighbours_ = 128;    // an element with more keeps only its grid
  static constexpr int kEndBlock = 8;  // cells a side of a block
  static constexpr int kEndBlocks = (kEndSide / kEndBlock) * (kEndSide / kEndBlock);
  struct EndReach {
    Vec3 origin, across, along, normal;
    Vec3 lo, hi;            // in (u, v, h)
    glm::dvec2 scale{0.0};  // cells per unit length in u and v
    size_t first_row = 0;
    bool listed = true;  // false: over the list budget, pieces in marked cells are traced
    // x in the frame: (u, v, h).
    Vec3 to_frame(const Vec3& x) const {
      const Vec3 p = x - origin;
      return Vec3(glm::dot(p, across), glm::dot(p, along), glm::dot(p, normal));
    }
    // World coordinate `axis` as a + u b + v c + h d: (b, c, d).
    Vec3 coefficients(int axis) const { return Vec3(across[axis], along[axis], normal[axis]); }
  };
  struct Neighbour {
    Vec3 lo, hi, normal;
    double offset = 0.0, thickness = 0.0;
  };
  std::vector<EndReach> end_reach_;
  std::vector<uint64_t> end_rows_;
  // Per element and block of kEndBlock x kEndBlock cells (index e kEndBlocks + bx + 8 by), the
  // neighbours that marked a cell in it: end_block_neighbours_ from end_block_first_[block] to
  // end_block_first_[block + 1].
  std::vector<uint32_t> end_block_first_, end_block_neighbours_;
  double end_piece_reach_ = 0.0;  // the longest piece, plus rounding
  std::vector<uint32_t> end_neighbours_first_;
  std::vector<Neighbour> end_neighbours_;
  bool end_prefilter_ = true;
  mutable std::atomic<uint64_t> end_pieces_traced_{0}, end_pieces_cleared_{0};
  // V is kept in steps of 1/kSteps (2^14: 6e-5, exact for equal-weight fractions of up to 4096
  // rays), so that the memo below holds it in 15 bits and every row sees the same V.
  // remember_pairs: per unordered pair (index hi (hi - 1) / 2 + lo), 0 unknown, else V's steps
  // + 1, with kTracedFlag when the pair needed rays; kBusy while one thread traces the pair.
  static constexpr int kSteps = 1 << 14;
  static constexpr uint16_t kTracedFlag = 0x8000, kCountMask = 0x7FFF, kBusy = 0xFFFF;
  mutable std::unique_ptr<std::atomic<uint16_t>[]> memo_;
  // Beside it, the standard error of each pair's V as sigma_code (written before the pair's memo_
  // slot is released, so a reader that sees V sees it).
  static constexpr double kSigmaSteps = 65536.0;
  static constexpr uint16_t kSigmaOne = 0xFFFF;
  mutable std::unique_ptr<uint16_t[]> memo_sigma_;
};

// 1e-9 of the scene's bounding-box diagonal: the distance below which points count as on a plane.
double plane_epsilon(const Mesh& mesh);

}  // namespace radlab
