#include "scene/overlap.h"

#include <algorithm>
#include <boost/geometry.hpp>  // the strategies (box distances) the R*-tree's inserts need
#include <boost/geometry/index/rtree.hpp>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <unordered_map>

#include "core/error.h"
#include "scene/geometry.h"

namespace radlab {
namespace geometry {
namespace {

// b's corners projected onto a's plane, wound counter-clockwise about a's normal.
std::vector<Vec3> project_onto(const std::vector<Vec3>& b, const Vec3& n, const Vec3& origin) {
  std::vector<Vec3> out;
  out.reserve(b.size());
  for (const Vec3& p : b) out.push_back(p - glm::dot(p - origin, n) * n);
  if (glm::dot(newell_vector(out), n) < 0) std::reverse(out.begin(), out.end());
  return out;
}

// Drops consecutive corners closer than 1e-12 of the polygon's size (clipping through a corner
// repeats it).
void tidy(std::vector<Vec3>& v) {
  if (v.size() < 2) return;
  const double scale = diameter(v);
  std::vector<Vec3> out;
  for (const Vec3& p : v)
    if (out.empty() || glm::distance(out.back(), p) > 1e-12 * scale) out.push_back(p);
  while (out.size() > 1 && glm::distance(out.front(), out.back()) <= 1e-12 * scale) out.pop_back();
  v = std::move(out);
}

}  // namespace

double overlap_area(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  const Vec3 n = unit_normal(a);
  const std::vector<Vec3> q = project_onto(b, n, a[0]);
  std::vector<Vec3> part = a, next;
  for (size_t k = 0; k < q.size() && part.size() >= 3; ++k) {
    const Vec3 inward = glm::cross(n, q[(k + 1) % q.size()] - q[k]);
    clip_to_halfspace(part, q[k], inward, next);
    part.swap(next);
  }
  return part.size() >= 3 ? area(part) : 0.0;
}

std::vector<std::vector<Vec3>> subtract_convex(const std::vector<Vec3>& a,
                                               const std::vector<Vec3>& b) {
  const Vec3 n = unit_normal(a);
  const std::vector<Vec3> q = project_onto(b, n, a[0]);
  const double tiny = 1e-9 * area(a);
  std::vector<std::vector<Vec3>> pieces;
  std::vector<Vec3> rest = a, outside, inside;
  // Outside edge k of b and inside edges 0..k-1: disjoint convex pieces whose union is a - b.
  for (size_t k = 0; k < q.size() && rest.size() >= 3; ++k) {
    const Vec3 inward = glm::cross(n, q[(k + 1) % q.size()] - q[k]);
    clip_to_halfspace(rest, q[k], -inward, outside);
    tidy(outside);
    if (outside.size() >= 3 && area(outside) > tiny) pieces.push_back(outside);
    clip_to_halfspace(rest, q[k], inward, inside);
    rest.swap(inside);
  }
  if (rest.size() < 3) {  // b does not reach into a: a is untouched
    pieces.assign(1, a);
  }
  return pieces;
}

}  // namespace geometry

namespace {

struct Plane {
  Vec3 normal;  // unit, facing as the polygon
  double offset = 0.0;
};

struct BucketKey {
  int64_t nx, ny, nz, d;
  bool operator==(const BucketKey&) const = default;
};

// Where the polygons placed so far lie: their bounding boxes in an R-tree (Boost.Geometry), so a
// polygon is compared only with those whose boxes meet its own, not with every earlier polygon
// of its plane (quadratic on a tessellated floor: bench/bench_loading.cpp).
namespace bg = boost::geometry;
namespace bgi = boost::geometry::index;
using BoxPoint = bg::model::point<double, 3, bg::cs::cartesian>;
using Box = bg::model::box<BoxPoint>;
using PlacedIndex = bgi::rtree<std::pair<Box, uint32_t>, bgi::rstar<16>>;

Box bounds(const std::vector<Vec3>& v, double margin) {
  Vec3 lo(v[0]), hi(v[0]);
  for (const Vec3& p : v) lo = glm::min(lo, p), hi = glm::max(hi, p);
  return {{lo.x - margin, lo.y - margin, lo.z - margin},
          {hi.x + margin, hi.y + margin, hi.z + margin}};
}

// Each convex piece of `polygon` (its area `own_area`) minus the convex polygon `b`, as convex
// pieces. Parts below kSliverFraction of the polygon's own area are dropped: they are rounding
// slivers along b's edges, and each later cut through a sliver makes more of them (subtract_convex
// floors them only against the piece being cut, so they were kept); a fuzzed scene of 1 kB grew
// one triangle into 663,552 such pieces, four times more with each polygon subtracted. What they
// held is in the repair's removed area (own area minus the pieces left), so the account holds.
// More than kMaxRepairPieces pieces is refused: the pieces are cells of the arrangement of the
// subtracted polygons' edge lines, O(k^2) for k of them, which no honest scene reaches.
void subtract_from_each(std::vector<std::vector<Vec3>>& pieces, const std::vector<Vec3>& b,
                        const Polygon& polygon, double own_area) {
  const double sliver = kSliverFraction * own_area;
  std::vector<std::vector<Vec3>> next;
  for (const auto& piece : pieces)
    for (auto& part : geometry::subtract_convex(piece, b))
      if (geometry::area(part) > sliver) next.push_back(std::move(part));
  if (next.size() > kMaxRepairPieces)
    throw InputError(polygon.origin + ": the coincident-overlap repair would cut this polygon " +
                     "into more than " + std::to_string(kMaxRepairPieces) +
                     " pieces (it overlaps that many coincident polygons); remove the duplicate " +
                     "polygons or pass --keep-overlaps");
  pieces = std::move(next);
}

std::string describe(const Scene& scene, const Polygon& p) {
  return p.origin + " ('" + scene.materials[size_t(p.material)].name + "')";
}

// The repair, polygon by polygon in the scene's order: each is compared with the earlier ones it
// may coincide with (find_candidates), each coincident pair is classified and settled
// (settle_pair), what is left of the polygon is placed, and the earlier sides of contacts lose
// their overlaps once every polygon is placed (cut_contacts).
class CoincidenceRepair {
 public:
  CoincidenceRepair(Scene& scene, bool keep, double diagonal)
      : scene_(scene),
        keep_(keep),
        diagonal_(diagonal),
        tolerance_(kCoincidentTolerance * diagonal),
        offset_step_(1e-4 * diagonal) {
    out_.reserve(scene.polygons.size());
  }

  OverlapReport run() {
    for (Polygon& polygon : scene_.polygons) add(polygon);
    if (!contact_cuts_.empty()) cut_contacts();
    scene_.polygons = std::move(out_);
    return std::move(report_);
  }

 private:
  // Buckets: the undirected normal quantised to 1e-3 and the offset to 1e-4 of the diagonal;
  // coincident polygons land in the same or a neighbouring bucket.
  BucketKey key_of(const Plane& plane) const {
    Vec3 n = plane.normal;
    double d = plane.offset;
    // Undirected: the largest component positive, so back-to-back polygons share buckets.
    const int axis = std::abs(n.x) >= std::abs(n.y) && std::abs(n.x) >= std::abs(n.z)
                         ? 0
                         : (std::abs(n.y) >= std::abs(n.z) ? 1 : 2);
    if (n[axis] < 0) n = -n, d = -d;
    return BucketKey{int64_t(std::floor(n.x / kNormalStep)), int64_t(std::floor(n.y / kNormalStep)),
                     int64_t(std::floor(n.z / kNormalStep)), int64_t(std::floor(d / offset_step_))};
  }

  bool coincident(const Polygon& a, const Plane& pa, const Polygon& b, const Plane& pb) const {
    if (std::abs(glm::dot(pa.normal, pb.normal)) < 1.0 - 1e-9) return false;
    for (const Vec3& v : b.vertices)
      if (std::abs(glm::dot(v, pa.normal) - pa.offset) > tolerance_) return false;
    for (const Vec3& v : a.vertices)
      if (std::abs(glm::dot(v, pb.normal) - pb.offset) > tolerance_) return false;
    return true;
  }

  // Candidates are the earlier polygons in the same or neighbouring buckets whose bounding boxes,
  // widened by twice the coincidence tolerance (b is projected onto a's plane by at most the
  // tolerance), meet the polygon's own: no other can overlap it. They are visited in the order
  // of the all-pairs loop this replaced (bucket offset, then placement), so the repair's results
  // are the same.
  void find_candidates(const Polygon& polygon, const BucketKey& key) {
    hits_.clear();
    placed_.query(bgi::intersects(bounds(polygon.vertices, 2.0 * tolerance_)),
                  std::back_inserter(hits_));
    candidates_.clear();
    for (const auto& [box, e] : hits_) {
      const BucketKey& other = keys_[e];
      const int64_t dx = other.nx - key.nx, dy = other.ny - key.ny, dz = other.nz - key.nz,
                    dd = other.d - key.d;
      if (std::abs(dx) > 1 || std::abs(dy) > 1 || std::abs(dz) > 1 || std::abs(dd) > 1) continue;
      candidates_.emplace_back(((dx + 1) * 27 + (dy + 1) * 9 + (dz + 1) * 3 + (dd + 1)), e);
    }
    std::sort(candidates_.begin(), candidates_.end());
  }

  void add(Polygon& polygon) {
    const Vec3 n = geometry::unit_normal(polygon.vertices);
    const Plane plane{n, glm::dot(n, geometry::centroid(polygon.vertices))};
    const BucketKey key = key_of(plane);
    const double own_area = geometry::area(polygon.vertices);
    std::vector<std::vector<Vec3>> pieces{polygon.vertices};
    bool cut = false;
    find_candidates(polygon, key);
    for (const auto& [offset, e] : candidates_)
      cut = settle_pair(e, polygon, plane, own_area, pieces) || cut;
    if (pieces.empty()) {
      ++report_.dropped;
      report_.removed_area += own_area;
      return;
    }
    if (cut) {
      ++report_.clipped;
      double left = 0.0;
      for (const auto& piece : pieces) left += geometry::area(piece);
      report_.removed_area += own_area - left;
    }
    for (auto& piece : pieces) {
      placed_.insert({bounds(piece, 0.0), uint32_t(out_.size())});
      keys_.push_back(key);
      planes_.push_back(plane);
      out_.push_back(Polygon{std::move(piece), polygon.material, polygon.origin});
    }
  }

  // The earlier polygon out_[e] against the later `polygon` (its plane, area and what is left
  // of it so far, `pieces`): nothing when they do not overlap; else counted, warned and, unless
  // kept, cut. Returns whether `pieces` was cut.
  bool settle_pair(uint32_t e, const Polygon& polygon, const Plane& plane, double own_area,
                   std::vector<std::vector<Vec3>>& pieces) {
    const Polygon& earlier = out_[e];
    if (!coincident(earlier, planes_[e], polygon, plane)) return false;
    const double shared = geometry::overlap_area(earlier.vertices, polygon.vertices);
    if (!(shared > 1e-6 * std::min(own_area, geometry::area(earlier.vertices))))
      return false;  // touching along an edge or at a corner
    const bool same = glm::dot(planes_[e].normal, plane.normal) > 0;
    char buffer[160];
    std::snprintf(buffer, sizeof buffer, " overlap by %.4g m^2 (%.3g%% of the later)", shared,
                  100.0 * shared / own_area);
    // Opposite normals: the later polygon's distance in front of the earlier one decides. In
    // front (face to face, each in front of the other) by more than rounding: a contact, such as
    // a window frame resting on a sill; behind: a two-sided sheet; within rounding of each other
    // the two cannot be told apart and the pair is kept as a sheet.
    const double gap =
        glm::dot(geometry::centroid(polygon.vertices) - geometry::centroid(earlier.vertices),
                 planes_[e].normal);
    const bool contact = !same && gap > kContactGap * diagonal_;
    if (!same)
      std::snprintf(buffer + std::strlen(buffer), sizeof buffer - std::strlen(buffer),
                    ", %.3g m apart", gap);
    const std::string what = describe(scene_, earlier) + " and " + describe(scene_, polygon) +
                             ": coincident " +
                             (same      ? "same-facing"
                              : contact ? "face-to-face"
                                        : "back-to-back") +
                             " polygons" + buffer;
    if (!same && !contact) {
      ++report_.back_to_back;
      report_.warnings.push_back(what + (gap > 0 ? "; kept (within rounding: a two-sided "
                                                   "sheet or a contact)"
                                                 : "; kept (a two-sided sheet)"));
      return false;
    }
    if (contact) {
      ++report_.contacts;
      report_.contact_area += shared;
      if (keep_) {
        report_.warnings.push_back(what + "; kept as they are (--keep-overlaps)");
        return false;
      }
      // Neither side of a contact sees anything but the other: light neither reaches it nor
      // leaves it, and the rays cannot resolve a gap this small (they would see past the other
      // polygon). Both lose the overlap; the earlier one in cut_contacts, once every polygon is
      // placed.
      contact_cuts_[e].push_back(polygon.vertices);
      subtract_from_each(pieces, earlier.vertices, polygon, own_area);
      report_.warnings.push_back(what + "; a contact: the overlap removed from both");
      return true;
    }
    ++report_.same_facing;
    report_.overlap_area += shared;
    if (keep_) {
      report_.warnings.push_back(what + "; kept as they are (--keep-overlaps)");
      return false;
    }
    subtract_from_each(pieces, earlier.vertices, polygon, own_area);
    report_.warnings.push_back(
        what + (pieces.empty() ? "; the later one dropped (wholly covered)"
                               : "; the later one cut to the " + std::to_string(pieces.size()) +
                                     " convex piece(s) outside the earlier"));
    return true;
  }

  // The earlier sides of contacts lose the overlaps with every later polygon they touch.
  void cut_contacts() {
    std::vector<Polygon> cut_out;
    cut_out.reserve(out_.size());
    for (uint32_t e = 0; e < out_.size(); ++e) {
      const auto found = contact_cuts_.find(e);
      if (found == contact_cuts_.end()) {
        cut_out.push_back(std::move(out_[e]));
        continue;
      }
      std::vector<std::vector<Vec3>> pieces{out_[e].vertices};
      const double own_area = geometry::area(out_[e].vertices);
      for (const std::vector<Vec3>& later : found->second)
        subtract_from_each(pieces, later, out_[e], own_area);
      ++(pieces.empty() ? report_.dropped : report_.clipped);
      report_.removed_area += own_area;
      for (const auto& piece : pieces) report_.removed_area -= geometry::area(piece);
      for (auto& piece : pieces)
        cut_out.push_back(Polygon{std::move(piece), out_[e].material, out_[e].origin});
    }
    out_ = std::move(cut_out);
  }

  static constexpr double kNormalStep = 1e-3;
  Scene& scene_;
  const bool keep_;
  const double diagonal_, tolerance_, offset_step_;
  OverlapReport report_;
  PlacedIndex placed_;           // the placed polygons' boxes
  std::vector<BucketKey> keys_;  // of each polygon in out_
  std::vector<Plane> planes_;    // of each polygon in out_
  std::vector<Polygon> out_;     // the polygons placed so far
  // Earlier polygons (indices into out_) and the later polygons in contact with them.
  std::unordered_map<uint32_t, std::vector<std::vector<Vec3>>> contact_cuts_;
  std::vector<std::pair<Box, uint32_t>> hits_;
  std::vector<std::pair<int64_t, uint32_t>> candidates_;  // (bucket offset, polygon in out_)
};

}  // namespace

OverlapReport resolve_coincident_polygons(Scene& scene, bool keep) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Polygon& p : scene.polygons)
    for (const Vec3& v : p.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
  const double diagonal = glm::length(hi - lo);
  if (!(diagonal > 0)) return {};
  return CoincidenceRepair(scene, keep, diagonal).run();
}

}  // namespace radlab
