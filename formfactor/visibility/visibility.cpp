#include "formfactor/visibility/visibility.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#define GLM_ENABLE_EXPERIMENTAL
#include <cstdlib>
#include <glm/gtx/norm.hpp>
#include <glm/vector_relational.hpp>
#include <limits>
#include <numeric>
#include <thread>

#include "core/random.h"
#include "formfactor/integrate/pair_geometry.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/visibility/occlusion.h"
#include "formfactor/visibility/sampling.h"

namespace radlab {

// The mesh's bounding-box diagonal (0 for no vertices).
static double diagonal_of(const Mesh& mesh) {
  Box box;
  for (const Vec3& v : mesh.vertices) box.grow(v);
  return mesh.vertices.empty() ? 0.0 : glm::length(box.hi - box.lo);
}

double plane_epsilon(const Mesh& mesh) {
  return 1e-9 * diagonal_of(mesh);
}

Visibility::Visibility(const Scene& scene, const Mesh& mesh, int rays, uint64_t seed,
                       bool shaft_culling, int max_rays, bool importance_close_pairs)
    : mesh_(mesh),
      importance_close_pairs_(importance_close_pairs),
      rays_(rays),
      max_rays_(max_rays),
      seed_(seed),
      plane_epsilon_(plane_epsilon(mesh)) {
  convex_enclosure_ = is_convex_enclosure(scene);
  if (convex_enclosure_) return;
  if (shaft_culling) shafts_ = std::make_unique<ShaftCuller>(scene, mesh, plane_epsilon_);
  embree_ = std::make_unique<EmbreeScene>(mesh);
  compute_own_polygon_margins();
  radius_ = element_radii(mesh);
  compute_end_neighbours();
}

// The skipped ends' pieces (trace_skipped_ends) are traced again with hits on the two ends' own
// polygons ignored, so only another polygon can block one, and only where it reaches the piece:
// for most pieces none comes near, and they need no ray. A piece spans at most the reach
// max(1e-4 diagonal, 1e-6 m) from its segment's end: t_near (and 1 - t_far) is at most 1e-4
// on segments of 1 cm or more and at most 1e-6 m / |d| on shorter ones (trace, trace_close), |d|
// at most the scene's diagonal. classify_pieces checks that bound and that the end lies in
// e's region (below); a piece that fails either is traced.
//
// e's region: in e's frame (u along `across`, v along `along`, h along the normal, from its
// centroid) the range of e's corners grown by twice the reach and the rounding margin (64 float
// ulps of the largest coordinate, for the ray's float origin and direction and Embree's float
// hit test, plus 1e-9 of the diagonal). An end inside it shrunk by the reach keeps its whole
// piece inside it. Listed for e: the elements c of other polygons whose boxes reach into the
// region's axis-aligned box (Embree's point query, then a box test), each as its box and its slab
// (the points within off_plane_[c] + float_error_ of its plane, where its float triangles lie),
// both grown by the margin. A hit on c lies in both, so a piece that misses either cannot be
// blocked by c; the slab matters where elements are tilted (their boxes overlap, their slabs
// meet only along shared edges).
//
// The grid: kEndSide x kEndSide cells over the region's (u, v) rectangle, each standing for the
// prism of its rectangle grown by the reach times the region's heights, so that it holds every
// piece whose end falls in the cell. A cell is marked when its prism meets some neighbour's box
// and slab: both are linear in (u, v, h), so their ranges over a prism come from the corner
// values axis by axis. The cells are grown by rounding slack (a millionth of a cell, 1e-12 of the
// coordinates), so that a point whose computed (u, v) falls in a cell lies in its prism. A piece
// whose end's cell is clear needs no look at the list. Which pieces are traced changes the cost
// only, never V: `set_end_prefilter(false)` traces them all (tests compare).
void Visibility::compute_end_neighbours() {
  const size_t n = mesh_.size();
  const double diagonal = diagonal_of(mesh_);
  const double margin = 8.0 * float_error_ + 1e-9 * diagonal;
  const double reach = 1.001 * std::max(1e-4 * diagonal, 1e-6) + margin;
  end_piece_reach_ = reach;
  std::vector<Box> boxes(n);
  for (size_t e = 0; e < n; ++e)
    for (uint32_t v : mesh_.element_vertices(e)) boxes[e].grow(mesh_.vertices[v]);
  end_reach_.resize(n);
  end_neighbours_first_.assign(n + 1, 0);
  end_neighbours_.clear();
  end_rows_.assign(n * kEndSide, 0);
  end_block_first_.assign(n * kEndBlocks + 1, 0);
  end_block_neighbours_.clear();
  const size_t budget = (size_t(32) << 20) + 1024 * n;
  size_t list_bytes = 0;
  std::vector<Neighbour> candidates;
  std::vector<uint64_t> block_masks;
  for (size_t e = 0; e < n; ++e) {
    Box region;
    end_reach_[e] = end_region(e, reach, margin, region);
    end_candidates(e, region, boxes, margin, candidates);
    // Only candidates that mark a cell are kept as neighbours: a piece is looked at against its
    // block's markers alone (a large tilted element's box holds many elements its plane never
    // comes near).
    block_masks.clear();
    for (const Neighbour& g : candidates) {
      const uint64_t blocks = mark_end_cells(end_reach_[e], g, reach);
      if (blocks == 0) continue;
      end_neighbours_.push_back(g);
      block_masks.push_back(blocks);
    }
    keep_end_lists(e, block_masks, budget, list_bytes);
  }
  end_block_first_[n * kEndBlocks] = uint32_t(end_block_neighbours_.size());
}

// x(u, v, h) = origin + u across + v along + h normal: each coordinate, and the distance from a
// plane, is a + u b + v c + h d, whose range over a box of (u, v, h) is the sum of the three
// terms' ranges (widened by the rounding of the sums).
static glm::dvec2 linear_range(double a, const Vec3& coefficient, const Vec3& q0, const Vec3& q1) {
  double sum_lo = a, sum_hi = a;
  for (int axis = 0; axis < 3; ++axis) {
    const double p0 = coefficient[axis] * q0[axis], p1 = coefficient[axis] * q1[axis];
    sum_lo += std::min(p0, p1), sum_hi += std::max(p0, p1);
  }
  const double round = 1e-12 * (std::abs(a) + std::abs(sum_lo) + std::abs(sum_hi));
  return glm::dvec2(sum_lo - round, sum_hi + round);
}

Visibility::EndReach Visibility::end_region(size_t e, double reach, double margin,
                                            Box& region) const {
  EndReach r;
  r.normal = mesh_.normal[e];
  r.origin = mesh_.centroid[e];
  const Vec3 helper = std::abs(r.normal.x) < 0.6 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  r.across = glm::normalize(glm::cross(r.normal, helper));
  r.along = glm::cross(r.normal, r.across);
  Vec3 low(std::numeric_limits<double>::infinity()), high(-low);
  for (uint32_t v : mesh_.element_vertices(e)) {
    const Vec3 q = r.to_frame(mesh_.vertices[v]);
    low = glm::min(low, q), high = glm::max(high, q);
  }
  const double grow = 2.0 * reach + 2.0 * margin;
  r.lo = low - Vec3(grow), r.hi = high + Vec3(grow);
  r.scale = double(kEndSide) / glm::max(glm::dvec2(r.hi) - glm::dvec2(r.lo), glm::dvec2(1e-300));
  r.first_row = e * kEndSide;
  for (int axis = 0; axis < 3; ++axis) {
    const glm::dvec2 extent = linear_range(r.origin[axis], r.coefficients(axis), r.lo, r.hi);
    region.lo[axis] = extent.x - margin, region.hi[axis] = extent.y + margin;
  }
  return r;
}

void Visibility::end_candidates(size_t e, const Box& region, const std::vector<Box>& boxes,
                                double margin, std::vector<Neighbour>& candidates) const {
  thread_local std::vector<uint32_t> found;
  found.clear();
  embree_->elements_near(0.5 * (region.lo + region.hi),
                         0.5 * glm::length(region.hi - region.lo) + margin, found);
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  candidates.clear();
  for (uint32_t c : found) {
    if (mesh_.polygon[c] == mesh_.polygon[e]) continue;  // ignored by the retrace
    Neighbour g;
    g.lo = boxes[c].lo - Vec3(margin), g.hi = boxes[c].hi + Vec3(margin);
    if (glm::any(glm::lessThan(g.hi, region.lo)) || glm::any(glm::greaterThan(g.lo, region.hi)))
      continue;
    g.normal = mesh_.normal[c];
    g.offset = glm::dot(g.normal, mesh_.centroid[c]);
    g.thickness = off_plane_[c] + float_error_ + 2.0 * margin;
    candidates.push_back(g);
  }
}

uint64_t Visibility::mark_end_cells(const EndReach& r, const Neighbour& g, double reach) {
  uint64_t* rows = end_rows_.data() + r.first_row;
  const glm::dvec2 size = 1.0 / r.scale;
  const glm::dvec2 slack =
      1e-6 * size + 1e-12 * (glm::abs(glm::dvec2(r.lo)) + glm::abs(glm::dvec2(r.hi)));
  uint64_t blocks = 0;  // the blocks of 8 x 8 cells where g marked a cell
  // The cells whose prisms may reach the neighbour's box: its corners' (u, v) range.
  glm::dvec2 gl(std::numeric_limits<double>::infinity()), gh(-gl);
  for (int corner = 0; corner < 8; ++corner) {
    const glm::dvec2 q(r.to_frame(Vec3(corner & 1 ? g.hi.x : g.lo.x, corner & 2 ? g.hi.y : g.lo.y,
                                       corner & 4 ? g.hi.z : g.lo.z)));
    gl = glm::min(gl, q), gh = glm::max(gh, q);
  }
  const glm::ivec2 first(glm::clamp((gl - glm::dvec2(r.lo) - slack - reach) * r.scale,
                                    glm::dvec2(0.0), glm::dvec2(kEndSide - 1)));
  const glm::ivec2 last(glm::clamp((gh - glm::dvec2(r.lo) + slack + reach) * r.scale,
                                   glm::dvec2(0.0), glm::dvec2(kEndSide - 1)));
  const double plane = glm::dot(g.normal, r.origin) - g.offset;
  const Vec3 toward(glm::dot(g.normal, r.across), glm::dot(g.normal, r.along),
                    glm::dot(g.normal, r.normal));
  // Row by row: each test is a + b u + (the v and h terms' range) against [low, high], a linear
  // condition on u, so the cells of a row that pass it are a run of columns, computed and then
  // widened by a cell on each side for rounding (marking more is safe).
  for (int y = first.y; y <= last.y; ++y) {
    const double v0 = r.lo.y + y * size.y - slack.y - reach;
    const double v1 = r.lo.y + (y + 1) * size.y + slack.y + reach;
    double from_x = double(first.x), to_x = double(last.x);
    const auto restrict_to = [&](double a, const Vec3& coefficient, double lower, double upper) {
      // The v and h terms' range over the row's prisms.
      const double cv0 = coefficient.y * v0, cv1 = coefficient.y * v1;
      const double ch0 = coefficient.z * r.lo.z, ch1 = coefficient.z * r.hi.z;
      const double rest_lo = std::min(cv0, cv1) + std::min(ch0, ch1);
      const double rest_hi = std::max(cv0, cv1) + std::max(ch0, ch1);
      const double b = coefficient.x;
      if (!(std::abs(b) > 1e-300)) {  // no dependence on u
        if (a + rest_lo > upper || a + rest_hi < lower) from_x = 1.0, to_x = 0.0;
        return;
      }
      // Some rest in its range puts a + b u + rest in [lower, upper] exactly when b u lies in
      // [lower - a - rest_hi, upper - a - rest_lo]; cell x spans u in [lo + x size - pad,
      // lo + (x + 1) size + pad].
      const double pad = slack.x + reach;
      const double u_a = (lower - a - rest_hi) / b, u_b = (upper - a - rest_lo) / b;
      const double u_min = std::min(u_a, u_b), u_max = std::max(u_a, u_b);
      // u in [u_min, u_max] must meet the cell's span: x from (u_min - lo - pad) / size - 1
      // to (u_max - lo + pad) / size.
      from_x = std::max(from_x, std::floor((u_min - r.lo.x - pad) / size.x - 1.0) - 1.0);
      to_x = std::min(to_x, std::ceil((u_max - r.lo.x + pad) / size.x) + 1.0);
    };
    restrict_to(plane, toward, -g.thickness, g.thickness);
    for (int axis = 0; axis < 3; ++axis)
      restrict_to(r.origin[axis], r.coefficients(axis), g.lo[axis], g.hi[axis]);
    if (!(from_x <= to_x)) continue;
    const int x0 = int(std::max(from_x, 0.0)), x1 = int(std::min(to_x, double(kEndSide - 1)));
    if (x0 > x1) continue;
    const uint64_t columns = (~uint64_t(0) >> (63 - x1)) & (~uint64_t(0) << x0);
    rows[y] |= columns;
    for (int x = x0; x <= x1; x += kEndBlock - x % kEndBlock)
      blocks |= uint64_t(1) << (x / kEndBlock + (kEndSide / kEndBlock) * (y / kEndBlock));
  }
  return blocks;
}

// Memory: the lists get a budget of 32 MB plus 1 KB an element, and an element has at most
// max_end_neighbours_ (128); past either, an element keeps its grid but not its lists, and its
// pieces in marked cells are traced (soda.mgf: 35,000 of 53,207 elements have 48 neighbours or
// more, and all lists would take 580 MB; examp1's take 0.4 MB).
void Visibility::keep_end_lists(size_t e, std::vector<uint64_t>& block_masks, size_t budget,
                                size_t& list_bytes) {
  EndReach& r = end_reach_[e];
  size_t bytes = (end_neighbours_.size() - end_neighbours_first_[e]) * sizeof(Neighbour);
  for (uint64_t blocks : block_masks) bytes += size_t(std::popcount(blocks)) * sizeof(uint32_t);
  r.listed = end_neighbours_.size() - end_neighbours_first_[e] <= max_end_neighbours_ &&
             list_bytes + bytes <= budget;
  if (r.listed) list_bytes += bytes;
  if (!r.listed) {
    end_neighbours_.resize(end_neighbours_first_[e]);
    block_masks.clear();
  }
  end_neighbours_first_[e + 1] = uint32_t(end_neighbours_.size());
  // Per block, the neighbours that marked a cell in it.
  for (int b = 0; b < kEndBlocks; ++b) {
    end_block_first_[e * kEndBlocks + size_t(b)] = uint32_t(end_block_neighbours_.size());
    for (uint32_t k = end_neighbours_first_[e]; k < end_neighbours_first_[e + 1]; ++k)
      if ((block_masks[k - end_neighbours_first_[e]] >> b) & 1u) end_block_neighbours_.push_back(k);
  }
}

// For every lane of `s`, what the grid says of its skipped piece next to `end` (at the segment's
// origin, or at o + d): kPieceClear, kPieceMarked (in a marked cell: the neighbours of
// block[lane] decide, piece_meets_a_neighbour) or kPieceTraced (longer than the reach, or its
// end outside end's region shrunk by the reach: traced). The arithmetic runs over all 16 lanes
// at once (unused lanes hold lane 0's values), so it vectorises.
void Visibility::classify_pieces(const SegmentPacket& s, size_t end, bool at_origin, uint8_t* state,
                                 uint32_t* block) const {
  if (!end_prefilter_ || end_reach_.empty()) {
    std::fill(state, state + 16, kPieceTraced);
    return;
  }
  const EndReach& r = end_reach_[end];
  const double reach = end_piece_reach_;
  alignas(64) int column[16], row[16], inside[16];
  for (int k = 0; k < 16; ++k) {
    const double dx = s.dx[k], dy = s.dy[k], dz = s.dz[k];
    const double span = at_origin ? double(s.t_near[k]) : 1.0 - double(s.t_far[k]);
    const bool short_piece =
        span * span * ((dx * dx + dy * dy) + dz * dz) * (1.0 + 1e-6) <= reach * reach;
    const double px = (at_origin ? double(s.ox[k]) : double(s.ox[k]) + dx) - r.origin.x;
    const double py = (at_origin ? double(s.oy[k]) : double(s.oy[k]) + dy) - r.origin.y;
    const double pz = (at_origin ? double(s.oz[k]) : double(s.oz[k]) + dz) - r.origin.z;
    const double u = (px * r.across.x + py * r.across.y) + pz * r.across.z;
    const double v = (px * r.along.x + py * r.along.y) + pz * r.along.z;
    const double h = (px * r.normal.x + py * r.normal.y) + pz * r.normal.z;
    inside[k] = short_piece & (u >= r.lo.x + reach) & (u <= r.hi.x - reach) &
                (v >= r.lo.y + reach) & (v <= r.hi.y - reach) & (h >= r.lo.z + reach) &
                (h <= r.hi.z - reach);
    const double cu = (u - r.lo.x) * r.scale.x, cv = (v - r.lo.y) * r.scale.y;
    column[k] = int(cu < 0.0 ? 0.0 : cu > kEndSide - 1.0 ? kEndSide - 1.0 : cu);
    row[k] = int(cv < 0.0 ? 0.0 : cv > kEndSide - 1.0 ? kEndSide - 1.0 : cv);
  }
  const uint64_t* rows = end_rows_.data() + r.first_row;
  for (int k = 0; k < s.count; ++k) {
    if (!inside[k]) {
      state[k] = kPieceTraced;
      continue;
    }
    state[k] = !((rows[row[k]] >> column[k]) & 1u) ? kPieceClear
               : r.listed                          ? kPieceMarked
                                                   : kPieceTraced;
    block[k] = uint32_t(end * kEndBlocks) + uint32_t(column[k] / kEndBlock) +
               uint32_t(kEndSide / kEndBlock) * uint32_t(row[k] / kEndBlock);
  }
}

// Whether the piece t in [t0, t1] of segment `lane` meets the box and slab of a neighbour that
// marked a cell of `block` (compute_end_neighbours).
bool Visibility::piece_meets_a_neighbour(const SegmentPacket& s, int lane, float t0, float t1,
                                         uint32_t block) const {
  const Vec3 o(s.ox[lane], s.oy[lane], s.oz[lane]), d(s.dx[lane], s.dy[lane], s.dz[lane]);
  // The float ray's points at t0 and t1, in double (the products of two floats are exact).
  const Vec3 a = o + double(t0) * d, b = o + double(t1) * d;
  const Vec3 lo = glm::min(a, b), hi = glm::max(a, b);
  for (uint32_t m = end_block_first_[block]; m < end_block_first_[block + 1]; ++m) {
    const Neighbour& g = end_neighbours_[end_block_neighbours_[m]];
    if (glm::any(glm::lessThan(g.hi, lo)) || glm::any(glm::greaterThan(g.lo, hi))) continue;
    const double sa = glm::dot(g.normal, a) - g.offset, sb = glm::dot(g.normal, b) - g.offset;
    if (std::min(sa, sb) <= g.thickness && std::max(sa, sb) >= -g.thickness) return true;
  }
  return false;
}

// Bounds for deciding when a pair's rays cannot meet i's or j's own polygon (see trace).
//
// off_plane_[e] bounds how far the float triangles Embree holds for e's polygon P, and e's own
// corners, lie from e's plane (through its centroid, along its normal). For any unit n_P and
// point c_P, with d_P = max over P's vertices v of |n_P.(v - c_P)| and R_P = max |v - c_P|:
//   |n_e.(v - c_e)| <= |n_P.(v - c_e)| + |n_e - n_P| |v - c_e| <= 2 d_P + 2 R_P |n_e - n_P|
// (c_e is a convex combination of P's vertices, so within d_P of P's plane). For a planar polygon
// this is rounding; for one left unsplit a little off its plane (validate.h) it is about its
// deviation. float_error_ covers the rounding of vertices and ray origins to float,
// 8 ulps of the largest coordinate.
void Visibility::compute_own_polygon_margins() {
  off_plane_.assign(mesh_.size(), 0.0);
  double largest = 0.0;
  for (const Vec3& v : mesh_.vertices)
    largest = std::max({largest, std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  float_error_ = 8.0 * 0x1p-24 * largest;
  const size_t polygons = mesh_.first_element_of_polygon.size() - 1;
  for (size_t P = 0; P < polygons; ++P) {
    const uint32_t first = mesh_.first_element_of_polygon[P];
    const uint32_t last = mesh_.first_element_of_polygon[P + 1];
    if (first == last) continue;
    const Vec3 n = mesh_.normal[first];
    const Vec3 c = mesh_.centroid[first];
    double flat = 0.0, radius = 0.0;
    for (uint32_t e = first; e < last; ++e)
      for (uint32_t v : mesh_.element_vertices(e)) {
        flat = std::max(flat, std::abs(glm::dot(n, mesh_.vertices[v] - c)));
        radius = std::max(radius, glm::distance(mesh_.vertices[v], c));
      }
    for (uint32_t e = first; e < last; ++e)
      off_plane_[e] = 2.0 * flat + 2.0 * radius * glm::distance(mesh_.normal[e], n);
  }
}

// Whether every segment from (a point of) element `from` to a point at least `height` above
// from's plane leaves from's polygon P before the parameter t_near >= 1e-4 (trace): it can then
// meet P only where Embree never looks, and needs no filter for P. With D = off_plane + float
// error, the segment's height is at least -(1-t) D + t (height - float error) and P lies below D,
// so a hit needs t <= 2D / (height + off_plane); safe with a factor 2 to spare when that is below
// 1e-4 / 2.
bool Visibility::leaves_own_polygon(size_t from, double height) const {
  const double D = off_plane_[from] + float_error_;
  return 4.0 * D < 1e-4 * (height + off_plane_[from]);
}

Visibility::~Visibility() = default;

std::vector<std::string> Visibility::left_out() const {
  if (convex_enclosure_)
    return {"visibility rays: none (the scene is a convex enclosure, nothing can occlude)"};
  if (shafts_)
    return {
        "visibility rays for pairs whose shaft holds no possible occluder (counted in "
        "pairs_unoccluded)"};
  return {};
}

bool Visibility::needs_rays(size_t i, size_t j) const {
  if (convex_enclosure_) return false;
  return !shafts_ || !shafts_->unoccluded(i, j);
}

int64_t Visibility::possible_blocker(size_t i, size_t j) const {
  if (convex_enclosure_) return -1;
  return shafts_ ? shafts_->first_blocker(i, j) : 0;
}

double Visibility::fraction(size_t i, size_t j, RowCost& cost, double* sigma_out) const {
  std::atomic<uint16_t>* slot = nullptr;
  size_t index = 0;
  if (memo_) {
    const size_t lo = std::min(i, j), hi = std::max(i, j);
    index = hi * (hi - 1) / 2 + lo;
    slot = &memo_[index];
    // Claim the pair, or wait for the thread that claimed it (a trace takes microseconds), so
    // each pair is traced exactly once and the counts do not depend on the schedule.
    uint16_t known = slot->load(std::memory_order_acquire);
    for (;;) {
      if (known == 0) {
        if (slot->compare_exchange_weak(known, kBusy, std::memory_order_acquire)) break;
      } else if (known == kBusy) {
        std::this_thread::yield();
        known = slot->load(std::memory_order_acquire);
      } else {  // the other row of the pair has been here: the same V, no work
        ++((known & kTracedFlag) ? cost.pairs_traced : cost.pairs_unoccluded);
        if (sigma_out) *sigma_out = sigma_of_code(memo_sigma_[index]);
        return double(int(known & kCountMask) - 1) / kSteps;
      }
    }
  }
  // Gives the claim back if the work throws, so no other thread waits for ever.
  struct Release {
    std::atomic<uint16_t>* slot;
    ~Release() {
      if (slot) slot->store(0, std::memory_order_release);
    }
  } release{slot};
  const bool traced = needs_rays(i, j);
  ++(traced ? cost.pairs_traced : cost.pairs_unoccluded);
  // A pair with a large form factor gets more rays: see rays_for.
  double sigma = 0.0;
  const int steps = traced ? trace(i, j, rays_for(i, j), cost, sigma) : kSteps;
  // What the memo holds, for this row too, so both rows of the pair see the same (larger) value.
  const uint16_t sigma_steps = sigma_code(sigma);
  if (sigma_out) *sigma_out = sigma_of_code(sigma_steps);
  if (slot) {
    memo_sigma_[index] = sigma_steps;
    slot->store(uint16_t((steps + 1) | (traced ? kTracedFlag : 0)), std::memory_order_release);
    release.slot = nullptr;
  }
  return double(steps) / kSteps;
}

uint16_t Visibility::sigma_code(double sigma) {
  // V lies in [0,1], so 1 bounds its error; NaN (no usable weight) is taken as that bound.
  if (!(sigma < 1.0)) return kSigmaOne;
  const double steps = std::ceil(std::max(sigma, 0.0) * kSigmaSteps);
  // Steps 65535 and 65536 both become the code for 1: rounded up, never down.
  return steps >= double(kSigmaOne) ? kSigmaOne : uint16_t(steps);
}

void Visibility::remember_pairs(bool on) const {
  const size_t n = mesh_.size();
  if (on && n >= 2) {
    memo_ = std::make_unique<std::atomic<uint16_t>[]>(n * (n - 1) / 2);  // zero: unknown
    memo_sigma_ = std::make_unique<uint16_t[]>(n * (n - 1) / 2);
  } else {
    memo_.reset();
    memo_sigma_.reset();
  }
}

// The parts of lo and hi the rays join: each element clipped to the other's front. Sample the
// region the unoccluded integral covers (raycast.cpp and exact.cpp clip i to j's front, and the
// point-to-polygon formula clips j to i's): rays from a part clipped away would be blocked by the
// very polygon that crosses the element and penalise the pair twice. False when a part is empty.
bool Visibility::facing_parts(size_t lo, size_t hi, FacingParts& parts) const {
  mesh_.corners(lo, parts.lo);
  mesh_.corners(hi, parts.hi);
  return clip_to_front(parts.lo, mesh_.centroid[hi], mesh_.normal[hi], plane_epsilon_,
                       &parts.lo_height) > 0.0 &&
         clip_to_front(parts.hi, mesh_.centroid[lo], mesh_.normal[lo], plane_epsilon_,
                       &parts.hi_height) > 0.0;
}

// The polygon whose hits the rays of the pair must ignore at element `own`'s end, or kNoPolygon.
// Hits on a pair's own polygons are rounding (a segment meets a planar polygon it leaves only at
// its end) and are filtered out, at the cost of an Embree callback per hit; where every segment
// provably leaves `own`'s polygon before t_near (the other element's facing part lies at least
// `height` above own's plane) no filter is needed (the filter was about 12% of the visibility
// time on the Cornell box).
uint32_t Visibility::own_polygon_to_skip(size_t own, double height) const {
  switch (own_polygon_filter_) {
    case OwnPolygonFilter::never:
      return EmbreeScene::kNoPolygon;
    case OwnPolygonFilter::always:
      return mesh_.polygon[own];
    case OwnPolygonFilter::automatic:
      break;
  }
  return leaves_own_polygon(own, height) ? EmbreeScene::kNoPolygon : mesh_.polygon[own];
}

int Visibility::own_polygons_filtered(size_t i, size_t j) const {
  if (!needs_rays(i, j)) return 0;
  const size_t lo = std::min(i, j), hi = std::max(i, j);
  FacingParts parts;
  if (!facing_parts(lo, hi, parts)) return 0;
  return (own_polygon_to_skip(lo, parts.hi_height) != EmbreeScene::kNoPolygon ? 1 : 0) +
         (own_polygon_to_skip(hi, parts.lo_height) != EmbreeScene::kNoPolygon ? 1 : 0);
}

// Rays for a pair that may be occluded: its V's sampling error, about F^u sqrt(V(1-V)/R), is
// kept near 0.025 / 4 x (F^u / 0.025) / sqrt(R / 16): R = rays (16 by default) while the pair's
// larger form factor is at most 0.025, 4x more per doubling of it, up to max_rays (4096). The
// size of the pair's larger form factor is judged symmetrically, from the areas and the
// centroids' distance (max(A_i, A_j) / (pi d^2), at most 1), so that V_ij = V_ji. On
// RenderPark's cube (one element per polygon, 10 m walls) 16 rays left row sums up to 1.03.
int Visibility::rays_for(size_t i, size_t j) const {
  if (max_rays_ <= rays_) return rays_;
  const double d2 = glm::distance2(mesh_.centroid[i], mesh_.centroid[j]);
  const double larger = std::min(1.0, std::max(mesh_.area[i], mesh_.area[j]) / (M_PI * d2));
  int R = rays_;
  for (double f = 0.025; f < larger && R * 4 <= max_rays_; f *= 2.0) R *= 4;
  return R;
}

// The standard error of the ratio estimate V = sum_k w_k b_k / sum_k w_k (b_k = 1 for an
// unblocked ray), by the delta method for independent rays:
//   Var V ~ sum_k w_k^2 (b_k - V)^2 / (sum_k w_k)^2,
// with sums of w and w^2 over all rays (W, S2) and over the unblocked ones (Wv, S2v). When every
// ray agrees this is 0, yet n rays cannot see a blocked (or open) share below ~1/n: the
// estimate is floored at the binomial variance of a share 1/(n + 2) (the add-one rule) with n the
// effective number of rays W^2 / S2 (Kish). Stratification makes the true error smaller; the
// rays are paired at random (a full shuffle in trace_close), so they are close to independent.
static double ratio_standard_error(double W, double Wv, double S2, double S2v) {
  if (!(W > 0.0) || !(S2 > 0.0)) return 0.5;  // no weight at all: nothing is known
  const double V = Wv / W;
  const double spread = (S2v * (1.0 - V) * (1.0 - V) + (S2 - S2v) * V * V) / (W * W);
  const double n = W * W / S2;
  const double p = 1.0 / (n + 2.0);
  return std::sqrt(std::max(spread, p * (1.0 - p) / (n + 1.0)));
}

// The kernel-weighted visible fraction of one pair's rays, accumulated packet by packet (both
// tracers below), and its standard error (ratio_standard_error).
struct WeightedVisibility {
  double weight_all = 0.0, weight_visible = 0.0, square_all = 0.0, square_visible = 0.0;
  int visible = 0;

  void add(const bool* blocked, const float* weight, int count) {
    for (int lane = 0; lane < count; ++lane) {
      visible += blocked[lane] ? 0 : 1;
      const double w = double(weight[lane]);
      weight_all += w;
      weight_visible += blocked[lane] ? 0.0 : w;
      square_all += w * w;
      square_visible += blocked[lane] ? 0.0 : w * w;
    }
  }
  // V of R rays in `steps` steps (the memo's resolution), the same whichever row asks, and its
  // standard error in `sigma`. Equal weights when every kernel sample vanished (points on the
  // planes' common line).
  int quantised(int R, int steps, double& sigma) const {
    sigma = weight_all > 0.0
                ? ratio_standard_error(weight_all, weight_visible, square_all, square_visible)
                : ratio_standard_error(R, visible, R, visible);
    const double v = weight_all > 0.0 ? weight_visible / weight_all : double(visible) / R;
    return int(std::lround(std::clamp(v, 0.0, 1.0) * steps));
  }
};

// The pieces of the unblocked segments that the ends' offsets (t_near, t_far: trace) left out,
// traced again with hits in the two ends' planes ignored instead. Those offsets keep a segment
// from meeting its own ends' polygons, or their coplanar neighbours, by rounding; but they also
// hid every polygon that crosses an end's plane within the offset: a wall the end element
// touches. Two closed rooms back to back (tests/formfactor/visibility/corner_leak_test.cpp) saw
// each other through their dividing wall: a ray ending on room B's side wall 9e-6 m from the wall's
// plane, from room A, crossed the wall 5e-6 m above the side wall's plane, inside the skipped 1 -
// t_far = 6e-5 of its length. Here a hit counts unless it lies in an end's plane (within that end's
// offset height, on a triangle parallel to it): a crossing polygon blocks however close to the
// end it crosses, a coplanar one never does. Only unblocked lanes need it; the pieces are short.
void Visibility::trace_skipped_ends(const SegmentPacket& segments, bool* blocked, size_t from,
                                    size_t to) const {
  constexpr float kEnd = 2.4e-7f;  // 4 float ulps of t near 1, as in trace
  thread_local SegmentPacket pieces;
  int lane_of[16];
  bool clear[16];  // proven clear by the prefilter (compute_end_neighbours)
  uint64_t traced = 0, cleared = 0;
  // The pieces go into packets of 16 in a fixed order, whatever the prefilter says, and a packet
  // is traced whole unless every piece in it is proven clear: Embree's answer for a ray that
  // grazes an edge can depend on the other rays of its packet (hospital.mgf: 2 of 35 M pairs
  // changed V when cleared pieces were left out of the packets), so the packets traced must be
  // the ones traced without the prefilter for V to keep its bits.
  const auto flush = [&] {
    if (pieces.count == 0) return;
    if (std::all_of(clear, clear + pieces.count, [](bool c) { return c; })) {
      cleared += uint64_t(pieces.count);
      pieces.count = 0;
      return;
    }
    traced += uint64_t(pieces.count);
    const auto plane = [&](size_t e) {
      return EmbreeScene::Plane{mesh_.centroid[e], mesh_.normal[e],
                                8.0 * (off_plane_[e] + float_error_)};
    };
    bool hit[16];
    embree_->occluded16_off_planes(pieces, hit, plane(from), plane(to), mesh_.polygon[from],
                                   mesh_.polygon[to]);
    for (int k = 0; k < pieces.count; ++k) blocked[lane_of[k]] |= hit[k];
    pieces.count = 0;
  };
  uint8_t near_state[16], far_state[16];
  uint32_t near_block[16], far_block[16];
  classify_pieces(segments, from, true, near_state, near_block);
  classify_pieces(segments, to, false, far_state, far_block);
  const auto add = [&](int lane, float t0, float t1, uint8_t state, uint32_t block) {
    if (!(t0 < t1)) return;
    if (pieces.count == 16) flush();
    const int k = pieces.count++;
    clear[k] = state == kPieceClear ||
               (state == kPieceMarked && !piece_meets_a_neighbour(segments, lane, t0, t1, block));
    pieces.ox[k] = segments.ox[lane], pieces.oy[k] = segments.oy[lane];
    pieces.oz[k] = segments.oz[lane];
    pieces.dx[k] = segments.dx[lane], pieces.dy[k] = segments.dy[lane];
    pieces.dz[k] = segments.dz[lane];
    pieces.t_near[k] = t0, pieces.t_far[k] = t1;
    lane_of[k] = lane;
  };
  pieces.count = 0;
  for (int lane = 0; lane < segments.count; ++lane) {
    if (blocked[lane]) continue;
    add(lane, kEnd, segments.t_near[lane], near_state[lane], near_block[lane]);
    add(lane, segments.t_far[lane], 1.0f - kEnd, far_state[lane], far_block[lane]);
  }
  flush();
  if (traced) end_pieces_traced_.fetch_add(traced, std::memory_order_relaxed);
  if (cleared) end_pieces_cleared_.fetch_add(cleared, std::memory_order_relaxed);
}

int Visibility::trace(size_t i, size_t j, int R, RowCost& cost, double& sigma) const {
  // Symmetric in i and j: the same points, the same rays, whichever row asks.
  const size_t lo = std::min(i, j), hi = std::max(i, j);
  Pcg32 rng(hash_combine(hash_combine(seed_, lo), hi));
  thread_local FacingParts parts;
  sigma = 0.0;
  if (!facing_parts(lo, hi, parts)) return kSteps;  // no unoccluded exchange to scale (F^u = 0)
  const std::vector<Vec3>& corners_lo = parts.lo;
  const std::vector<Vec3>& corners_hi = parts.hi;
  const uint32_t skip_lo = own_polygon_to_skip(lo, parts.hi_height);
  const uint32_t skip_hi = own_polygon_to_skip(hi, parts.lo_height);
  cost.rays += uint64_t(R);
  if (close_pair(lo, hi) && parts.lo.size() <= SolidAngleSampler::kMaxCorners &&
      parts.hi.size() <= SolidAngleSampler::kMaxCorners)
    return trace_close(lo, hi, parts, R, skip_lo, skip_hi, sigma);
  // R strata of an m x m grid on each element (all of them, in order, when R = m^2, the default
  // 16), stratum k of lo paired with stratum (a k + b) mod R of hi: a random affine permutation,
  // a odd and prime to R (any odd a when R is a power of two). The jitter of ray k comes from one
  // hash of (pair key, k): no serial generator, so the lanes vectorise.
  const int m = int(std::ceil(std::sqrt(double(R))));
  const bool every_stratum = m * m == R;  // stratum k is then index k: no lists to make
  thread_local std::vector<uint32_t> all_lo, all_hi;
  if (!every_stratum) {
    choose_strata(R, m, rng, all_lo);
    choose_strata(R, m, rng, all_hi);
  }
  const StratifiedSampler from(corners_lo, m), to(corners_hi, m);
  const bool power_of_two = (R & (R - 1)) == 0;
  uint32_t a = rng.next_u32() | 1u;
  if (!power_of_two)
    while (std::gcd(a % uint32_t(R), uint32_t(R)) != 1) a += 2;
  const uint32_t b = rng.next_u32();
  const uint64_t key = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
  thread_local SegmentPacket packet;
  alignas(64) uint32_t strata_lo[16], strata_hi[16], bits_lo[16], bits_hi[16];
  alignas(64) float qx[16], qy[16], qz[16];
  bool blocked[16];
  // Each ray weighs its kernel cos_lo cos_hi / r^2 (below): V = sum over unblocked rays / sum
  // over all, the ratio estimator of (integral of K V) / (integral of K) from the same points.
  const Vec3 n_lo = mesh_.normal[lo], n_hi = mesh_.normal[hi];
  const float nlx = float(n_lo.x), nly = float(n_lo.y), nlz = float(n_lo.z);
  const float nhx = float(n_hi.x), nhy = float(n_hi.y), nhz = float(n_hi.z);
  alignas(64) float weight[16];
  const float lift_lo = float(8.0 * (off_plane_[lo] + float_error_));
  const float lift_hi = float(8.0 * (off_plane_[hi] + float_error_));
  WeightedVisibility fraction;
  for (int start = 0; start < R; start += 16) {
    const int count = std::min(16, R - start);
    packet.count = count;
    for (int lane = 0; lane < count; ++lane) {
      const uint32_t k = uint32_t(start + lane);
      const uint32_t l = power_of_two ? (a * k + b) & uint32_t(R - 1)
                                      : uint32_t((uint64_t(a) * k + b) % uint64_t(R));
      strata_lo[lane] = every_stratum ? k : all_lo[k];
      strata_hi[lane] = every_stratum ? l : all_hi[l];
      const uint64_t r = mix64(key + k);
      bits_lo[lane] = uint32_t(r);
      bits_hi[lane] = uint32_t(r >> 32);
    }
    from.points(strata_lo, bits_lo, count, packet.ox, packet.oy, packet.oz);
    to.points(strata_hi, bits_hi, count, qx, qy, qz);
    for (int lane = 0; lane < count; ++lane) {
      const float dx = qx[lane] - packet.ox[lane], dy = qy[lane] - packet.oy[lane],
                  dz = qz[lane] - packet.oz[lane];
      packet.dx[lane] = dx, packet.dy[lane] = dy, packet.dz[lane] = dz;
      // Parameters along the segment: skip its two ends, where it touches i and j. Far enough
      // that the segment is 8 D above the end's plane there (D: the element's polygon's distance
      // from its plane plus float rounding, compute_own_polygon_margins), so it can no longer
      // meet that polygon or a coplanar neighbour; no farther, so that a surface stacked a little
      // above j (a rug on a floor, a sheet on a desk) still blocks the rays that end on j. Never
      // more than the fixed offset used before (1e-4 of the length, at least 1e-6 m on segments
      // under 1 cm), where the own-polygon filter rule (leaves_own_polygon) was made; never less
      // than 4 float ulps of t near 1.
      const float length2 = dx * dx + dy * dy + dz * dz;
      const float eps = length2 >= 1e-4f ? 1e-4f : 1e-6f / std::sqrt(std::max(length2, 1e-30f));
      const float c_lo = std::max(0.0f, nlx * dx + nly * dy + nlz * dz);     // heights of the
      const float c_hi = std::max(0.0f, -(nhx * dx + nhy * dy + nhz * dz));  // other end
      packet.t_near[lane] = std::min(eps, std::max(lift_lo / std::max(c_lo, 1e-30f), 2.4e-7f));
      packet.t_far[lane] =
          1.0f - std::min(eps, std::max(lift_hi / std::max(c_hi, 1e-30f), 2.4e-7f));
      weight[lane] = c_lo * c_hi / std::max(length2 * length2, 1e-30f);
    }
    if (!from.uniform() || !to.uniform())  // a clipped trapezoid: weigh by the points' density
      for (int lane = 0; lane < count; ++lane)
        weight[lane] *= float(from.area_weight(strata_lo[lane], bits_lo[lane]) *
                              to.area_weight(strata_hi[lane], bits_hi[lane]));
    embree_->occluded16(packet, blocked, skip_lo, skip_hi);
    trace_skipped_ends(packet, blocked, lo, hi);
    fraction.add(blocked, weight, count);
  }
  return fraction.quantised(R, kSteps, sigma);
}

}  // namespace radlab

namespace radlab {

// The kernel cos cos / r^2 varies over the larger element by ((d + r) / (d - r))^2, d the
// centroids' distance and r the larger element's radius: above r = d / 4 (a factor 2.8) the
// uniform points' weights spread enough to matter (a 33 cm^2 chair piece 0.23 m from a 1.2 m^2
// cabinet side on office2: F between 0.561 and 0.640 over six seeds at 4,096 rays). Depends only
// on the unordered pair, so V_ij = V_ji.
bool Visibility::close_pair(size_t lo, size_t hi) const {
  if (!importance_close_pairs_) return false;
  const double r = std::max(radius_[lo], radius_[hi]);
  return 4.0 * r > glm::distance(mesh_.centroid[lo], mesh_.centroid[hi]);
}

// V of a close pair, importance-sampled: points x_k stratified uniformly on the smaller element's
// facing part (the source; lo on a tie), and for each a point y_k of the other part drawn
// uniformly in the solid angle it subtends at x_k (SolidAngleSampler), so with density
// cos_y / (r^2 Omega(x_k)). The ray's weight K(x, y) / density is then Omega(x_k) cos_x(y_k)
// (times the source's area weight on a non-parallelogram quad): bounded by 2 pi, where the
// uniform points' weight A K is unbounded as the elements approach. V is the same ratio
// estimator as in trace, sum over unblocked rays / sum over all, exact (1) when nothing blocks.
// Symmetric: the roles follow from the unordered pair, and the points from its seed.
int Visibility::trace_close(size_t lo, size_t hi, const FacingParts& parts, int R, uint32_t skip_lo,
                            uint32_t skip_hi, double& sigma) const {
  const bool lo_is_source = mesh_.area[lo] <= mesh_.area[hi];
  const size_t source = lo_is_source ? lo : hi, target = lo_is_source ? hi : lo;
  const std::vector<Vec3>& from_part = lo_is_source ? parts.lo : parts.hi;
  const std::vector<Vec3>& to_part = lo_is_source ? parts.hi : parts.lo;
  Pcg32 rng(hash_combine(hash_combine(seed_, lo), hi));
  const int m = int(std::ceil(std::sqrt(double(R))));
  thread_local std::vector<uint32_t> strata_from, strata_to;
  choose_strata(R, m, rng, strata_from);
  choose_strata(R, m, rng, strata_to);
  // Source stratum k goes with direction stratum strata_to[k] after a full shuffle. Not the affine
  // permutation trace uses: with R = m^2, l = a k + b (mod R) makes the direction's column a
  // function of the source's column alone, so the pairs lie on m lines of the joint square; the
  // ratio then varied over seeds several times its standard error (corridor.mgf's torus element
  // to its 100 m^2 wall: 0.949 and 0.955 for seeds 0 and 1, 0.896-0.922 for ten others).
  for (uint32_t k = uint32_t(R) - 1; k > 0; --k)
    std::swap(strata_to[k], strata_to[rng.next_below(k + 1)]);
  const uint64_t key = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
  const StratifiedSampler from(from_part, m);
  const Vec3 n_from = mesh_.normal[source], n_to = mesh_.normal[target];
  const float lift_from = float(8.0 * (off_plane_[source] + float_error_));
  const float lift_to = float(8.0 * (off_plane_[target] + float_error_));
  thread_local SegmentPacket packet;
  alignas(64) float weight[16];
  bool blocked[16];
  WeightedVisibility fraction;
  thread_local SolidAngleLanes toward;
  uint32_t lane_stratum[16], lane_bits[16];
  // m is a power of two for the default ray counts (16 4^k): shifts for the divisions, and
  // 1/m exact, so the same bits as dividing.
  const bool power_of_two = (m & (m - 1)) == 0;
  const uint32_t mask = uint32_t(m) - 1, shift = uint32_t(std::countr_zero(uint32_t(m)));
  const double inverse_m = 1.0 / m;
  const auto column = [&](uint32_t s) { return power_of_two ? s & mask : s % uint32_t(m); };
  const auto row = [&](uint32_t s) { return power_of_two ? s >> shift : s / uint32_t(m); };
  const auto per_side = [&](double t) { return power_of_two ? t * inverse_m : t / m; };
  for (int start = 0; start < R; start += 16) {
    const int count = std::min(16, R - start);
    packet.count = count;
    for (int lane = 0; lane < count; ++lane) {
      const uint32_t k = uint32_t(start + lane);
      const uint32_t s_from = strata_from[k], s_to = strata_to[k];
      const uint64_t bits = mix64(key + k);
      const uint32_t bits_from = uint32_t(bits), bits_to = uint32_t(bits >> 32);
      const Vec3 x = from.point(int(column(s_from)), int(row(s_from)), bits_from);
      toward.x[0][lane] = x.x, toward.x[1][lane] = x.y, toward.x[2][lane] = x.z;
      toward.u[lane] = per_side(column(s_to) + ((bits_to & 0xFFFFu) + 0.5) * 0x1p-16);
      toward.v[lane] = per_side(row(s_to) + ((bits_to >> 16) + 0.5) * 0x1p-16);
      lane_stratum[lane] = s_from, lane_bits[lane] = bits_from;
    }
    // y_k drawn uniformly in the solid angle of the target's part seen from x_k.
    sample_solid_angles(to_part, n_to, count, toward);
    // The rays, lane arrays over all 16 (unused lanes repeat lane 0) so that the loops vectorise:
    // glm's dot, length and std::max written out in their order of operations.
    alignas(64) double along_from[16], along_to[16], cos_from[16];
    for (int lane = 0; lane < 16; ++lane) {
      const double dx = toward.y[0][lane] - toward.x[0][lane];
      const double dy = toward.y[1][lane] - toward.x[1][lane];
      const double dz = toward.y[2][lane] - toward.x[2][lane];
      const double length = std::sqrt((dx * dx + dy * dy) + dz * dz);
      along_from[lane] = (n_from.x * dx + n_from.y * dy) + n_from.z * dz;
      along_to[lane] = (n_to.x * dx + n_to.y * dy) + n_to.z * dz;
      const double cosine = along_from[lane] / length;
      cos_from[lane] = length > 0.0 ? (0.0 < cosine ? cosine : 0.0) : 0.0;
      packet.ox[lane] = float(toward.x[0][lane]), packet.oy[lane] = float(toward.x[1][lane]);
      packet.oz[lane] = float(toward.x[2][lane]);
      packet.dx[lane] = float(dx), packet.dy[lane] = float(dy), packet.dz[lane] = float(dz);
    }
    if (from.uniform())
      for (int lane = 0; lane < 16; ++lane)
        weight[lane] = float(toward.omega[lane] * cos_from[lane]);
    else  // a clipped trapezoid: weigh by the points' density
      for (int lane = 0; lane < count; ++lane)
        weight[lane] = float(toward.omega[lane] * cos_from[lane] *
                             from.area_weight(lane_stratum[lane], lane_bits[lane]));
    for (int lane = 0; lane < 16; ++lane) {
      // The ends as in trace: far enough from each end's plane to leave its own polygon.
      const float dx = packet.dx[lane], dy = packet.dy[lane], dz = packet.dz[lane];
      const float length2 = dx * dx + dy * dy + dz * dz;
      const float eps = length2 >= 1e-4f ? 1e-4f : 1e-6f / std::sqrt(std::max(length2, 1e-30f));
      const float c_from = std::max(0.0f, float(along_from[lane]));
      const float c_to = std::max(0.0f, -float(along_to[lane]));
      packet.t_near[lane] = std::min(eps, std::max(lift_from / std::max(c_from, 1e-30f), 2.4e-7f));
      packet.t_far[lane] =
          1.0f - std::min(eps, std::max(lift_to / std::max(c_to, 1e-30f), 2.4e-7f));
    }
    embree_->occluded16(packet, blocked, skip_lo, skip_hi);
    trace_skipped_ends(packet, blocked, source, target);
    fraction.add(blocked, weight, count);
  }
  return fraction.quantised(R, kSteps, sigma);
}

}  // namespace radlab
