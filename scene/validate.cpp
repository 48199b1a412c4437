#include "scene/validate.h"

#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "core/log.h"
#include "core/text.h"
#include "scene/geometry.h"
#include "scene/triangulate.h"

namespace radlab {
namespace {

void check_material(const Material& m) {
  for (int c = 0; c < 3; ++c) {
    double rho = m.reflectance[c];
    if (!(rho >= 0.0 && rho <= 1.0))  // also rejects NaN
      throw InputError("material '" + m.name + "': reflectance must lie in [0,1] in every channel" +
                       ", got " + std::to_string(rho) + " in channel " + "rgb"[c]);
    double e = m.emission[c];
    // Bounded, not only finite: radiosities reach E / (1 - rho) and the error metrics square
    // them, which overflows double near 1e154 (emission=1e308 printed rms_rel -nan). Nothing
    // physical comes near the bound (the Sun's surface emits 6.3e7 W/m^2).
    if (!(e >= 0.0 && e <= kMaxEmission))
      throw InputError("material '" + m.name + "': emission must lie in [0, 1e30], got " +
                       text::format_double(e) + " in channel " + "rgb"[c]);
  }
}

std::vector<Vec3> merge_repeated(const std::vector<Vec3>& v) {
  double scale = geometry::diameter(v);
  std::vector<Vec3> out;
  for (const Vec3& p : v)
    if (out.empty() || glm::distance(out.back(), p) > 1e-12 * scale) out.push_back(p);
  while (out.size() > 1 && glm::distance(out.front(), out.back()) <= 1e-12 * scale) out.pop_back();
  return out;
}

// Splits a non-planar polygon into triangles: a quad along its shorter diagonal, a polygon that
// is convex in projection as a fan from its first corner, any other by the constrained
// triangulation of its projection (a fan would cover what lies outside it).
std::vector<std::vector<Vec3>> split_non_planar(const std::vector<Vec3>& v) {
  std::vector<std::vector<Vec3>> out;
  if (!geometry::is_convex(v)) return triangulate_polygon(v);
  if (v.size() == 4) {
    if (glm::distance(v[0], v[2]) <= glm::distance(v[1], v[3])) {
      out.push_back({v[0], v[1], v[2]});
      out.push_back({v[0], v[2], v[3]});
    } else {
      out.push_back({v[0], v[1], v[3]});
      out.push_back({v[1], v[2], v[3]});
    }
    return out;
  }
  for (size_t i = 1; i + 1 < v.size(); ++i) out.push_back({v[0], v[i], v[i + 1]});
  return out;
}

// Whether two edges of the polygon, not neighbours, cross at a point inside both (a pentagram,
// a bow tie): its turns can all agree (a pentagram passes the convexity test, winding twice),
// but no split into triangles covers it honestly. Edges that only touch or overlap along a
// line (the seam of a face with a hole, common in MGF exports) do not count.
// Works in the plane of the largest Newell component; O(n^2) pairs, n <= kMaxPolygonCorners.
bool self_intersecting(const std::vector<Vec3>& v, size_t& first, size_t& second) {
  const size_t n = v.size();
  if (n < 4) return false;
  const Vec3 normal = geometry::newell_vector(v);
  int drop = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(normal[k]) > std::abs(normal[drop])) drop = k;
  const int a = (drop + 1) % 3, b = (drop + 2) % 3;
  const double d = geometry::diameter(v);
  const double eps = 1e-9 * d * d;
  auto orient = [&](const Vec3& p, const Vec3& q, const Vec3& r) {
    return (q[a] - p[a]) * (r[b] - p[b]) - (q[b] - p[b]) * (r[a] - p[a]);
  };
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // neighbours through the closing edge
      const Vec3 &p = v[i], &q = v[(i + 1) % n], &r = v[j], &t = v[(j + 1) % n];
      const double o1 = orient(p, q, r), o2 = orient(p, q, t);
      const double o3 = orient(r, t, p), o4 = orient(r, t, q);
      if (((o1 > eps && o2 < -eps) || (o1 < -eps && o2 > eps)) &&
          ((o3 > eps && o4 < -eps) || (o3 < -eps && o4 > eps))) {
        first = i;
        second = j;
        return true;
      }
    }
  return false;
}

bool degenerate(const std::vector<Vec3>& v) {
  if (v.size() < 3) return true;
  double d = geometry::diameter(v);
  // Zero area, or a sliver whose area is at rounding level for its size.
  return !(geometry::area(v) > 1e-12 * d * d) || !(d > 0);
}

}  // namespace

namespace {

// What no repair can fix, refused before any all-pairs geometry (diameter, triangulation) runs on
// the polygon: a material that does not exist, more corners than kMaxPolygonCorners, a coordinate
// that is not finite or beyond kMaxCoordinate.
void refuse_unusable(const Scene& scene, const Polygon& polygon) {
  if (polygon.material < 0 || size_t(polygon.material) >= scene.materials.size())
    throw InputError(polygon.origin + ": polygon refers to a material that does not exist");
  if (polygon.vertices.size() > kMaxPolygonCorners)
    throw InputError(polygon.origin + ": polygon has " + std::to_string(polygon.vertices.size()) +
                     " corners; radlab accepts at most " + std::to_string(kMaxPolygonCorners) +
                     " (split it into smaller polygons)");
  for (const Vec3& p : polygon.vertices)
    if (!(std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate &&
          std::abs(p.z) <= kMaxCoordinate))
      throw InputError(polygon.origin + ": polygon has a vertex coordinate that is not finite " +
                       "or beyond 1e12 m (areas and kernels would overflow)");
}

// A non-planar or non-convex polygon (corners v, area `read`) split into `pieces`, kept, and
// accounted for: the pieces' areas projected on the polygon's plane add up to the polygon's
// (Newell's vector is additive over any subdivision, planar or not; a piece wound the wrong way
// subtracts), so a difference beyond rounding is area the split lost (or invented), and named.
void keep_pieces(const Polygon& polygon, const std::vector<Vec3>& v, double read,
                 std::vector<std::vector<Vec3>> pieces, const std::string& what,
                 ValidationReport& report, std::vector<Polygon>& kept) {
  ++report.triangulated;
  std::erase_if(pieces, [](const std::vector<Vec3>& piece) { return degenerate(piece); });
  const Vec3 normal = geometry::unit_normal(v);
  double projected = 0.0, surface = 0.0;
  // Newell's sum takes products of coordinates, so it rounds by ~1e-16 of their square: taken
  // about the polygon's first corner, that is the square of the polygon's size, not of its
  // distance from the origin (1e24 m^2 at 1e12 m).
  std::vector<Vec3> shifted;
  for (const auto& piece : pieces) {
    shifted.clear();
    for (const Vec3& p : piece) shifted.push_back(p - v[0]);
    projected += 0.5 * glm::dot(geometry::newell_vector(shifted), normal);
    surface += geometry::area(piece);
  }
  report.area.kept_before_overlaps += surface;
  report.area.non_planar_surplus += surface - projected;
  if (std::abs(projected - read) > kAreaTolerance * read) {
    report.area.split_lost += read - projected;
    report.warnings.push_back(polygon.origin + what + std::to_string(pieces.size()) +
                              " triangles covering " + text::format_double(projected) + " of its " +
                              text::format_double(read) + " m^2 (" +
                              text::format_double(std::abs(read - projected)) + " m^2 " +
                              (read > projected ? "lost)" : "more)"));
  } else {
    report.warnings.push_back(polygon.origin + what + std::to_string(pieces.size()) + " triangles");
  }
  for (auto& piece : pieces)
    kept.push_back(Polygon{std::move(piece), polygon.material, polygon.origin});
}

// One polygon read: dropped (degenerate), refused (self-intersecting), kept as it is, or split
// into triangles (non-planar, non-convex), with its area in the account.
void validate_polygon(Polygon& polygon, ValidationReport& report, std::vector<Polygon>& kept) {
  const double read = geometry::area(polygon.vertices);
  report.area.read += read;
  std::vector<Vec3> v = merge_repeated(polygon.vertices);
  if (degenerate(v)) {
    report.warnings.push_back(polygon.origin + ": zero-area or degenerate polygon (" +
                              std::to_string(polygon.vertices.size()) + " vertices, " +
                              text::format_double(read) + " m^2) dropped");
    ++report.dropped;
    report.area.dropped += read;
    return;
  }
  size_t first = 0, second = 0;
  if (self_intersecting(v, first, second))
    throw InputError(polygon.origin + ": self-intersecting polygon (its edges " +
                     std::to_string(first + 1) + " and " + std::to_string(second + 1) +
                     " cross); split it into simple polygons");
  const double defect = geometry::planarity_defect(v);
  const double diameter = geometry::diameter(v);
  if (defect > kPlanarityTolerance * diameter) {
    keep_pieces(polygon, v, read, split_non_planar(v),
                ": non-planar polygon (off its plane by " + std::to_string(defect) + " m, " +
                    std::to_string(defect / diameter) + " of its size) split into ",
                report, kept);
  } else if (!geometry::is_convex(v)) {
    keep_pieces(polygon, v, read, triangulate_polygon(v), ": non-convex polygon split into ",
                report, kept);
  } else {
    report.area.kept_before_overlaps += read;
    polygon.vertices = std::move(v);
    kept.push_back(std::move(polygon));
  }
}

}  // namespace

ValidationReport validate_scene(Scene& scene, bool keep_overlaps) {
  ValidationReport report;
  for (const Material& m : scene.materials) check_material(m);
  std::vector<Polygon> kept;
  kept.reserve(scene.polygons.size());
  for (Polygon& polygon : scene.polygons) {
    refuse_unusable(scene, polygon);
    validate_polygon(polygon, report, kept);
  }
  scene.polygons = std::move(kept);
  if (!scene.polygons.empty()) {
    report.overlaps = resolve_coincident_polygons(scene, keep_overlaps);
    for (std::string& w : report.overlaps.warnings) report.warnings.push_back(std::move(w));
  }
  report.area.overlaps_removed = report.overlaps.removed_area;
  for (const Polygon& p : scene.polygons) report.area.kept += geometry::area(p.vertices);
  if (!report.area.balanced())
    report.warnings.push_back(
        scene.name + ": " + text::format_double(report.area.unaccounted()) + " m^2 of the " +
        text::format_double(report.area.read) + " m^2 read is lost without a warning naming it (" +
        text::format_double(report.area.kept) + " m^2 kept); please report this as a bug");
  if (scene.polygons.empty())
    throw InputError(scene.name + ": the scene has no usable polygons" +
                     (report.overlaps.dropped > 0
                          ? " (coincident overlaps and contacts removed them all; "
                            "--keep-overlaps keeps them)"
                          : ""));
  return report;
}

void require_emitter(const Scene& scene) {
  for (const Polygon& p : scene.polygons)
    if (scene.materials[size_t(p.material)].emits()) return;
  throw InputError(scene.name +
                   ": the scene has no emitter (no material with emission > 0), so every "
                   "radiosity is zero; give a material Ke (OBJ/MTL) or ed (MGF)");
}

void print_warnings(const ValidationReport& report) {
  const size_t shown = 8;
  for (size_t i = 0; i < report.warnings.size() && i < shown; ++i) log::warning(report.warnings[i]);
  if (report.warnings.size() > shown)
    log::warning(std::to_string(report.warnings.size() - shown) + " more warnings like these (" +
                 std::to_string(report.dropped) + " polygons dropped, " +
                 std::to_string(report.triangulated) + " split, " +
                 std::to_string(report.overlaps.same_facing) + " coincident same-facing and " +
                 std::to_string(report.overlaps.back_to_back) + " back-to-back and " +
                 std::to_string(report.overlaps.contacts) + " face-to-face overlaps in all)");
}

}  // namespace radlab
