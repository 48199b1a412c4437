#include "scene/validate.h"

#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "core/log.h"
#include "core/text.h"
#include "scene/geometry.h"

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

// Ear clipping in the polygon's own plane; for non-convex planar polygons.
std::vector<std::vector<Vec3>> ear_clip(const std::vector<Vec3>& v) {
  Vec3 n = geometry::unit_normal(v);
  std::vector<size_t> idx(v.size());
  for (size_t i = 0; i < v.size(); ++i) idx[i] = i;
  std::vector<std::vector<Vec3>> triangles;
  auto turn = [&](const Vec3& a, const Vec3& b, const Vec3& c) {
    return glm::dot(glm::cross(b - a, c - b), n);
  };
  auto inside = [&](const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
    return turn(a, b, p) >= 0 && turn(b, c, p) >= 0 && turn(c, a, p) >= 0;
  };
  size_t guard = 0;
  while (idx.size() > 3 && guard++ < 10 * v.size() * v.size()) {
    bool clipped = false;
    for (size_t k = 0; k < idx.size(); ++k) {
      size_t ia = idx[(k + idx.size() - 1) % idx.size()], ib = idx[k],
             ic = idx[(k + 1) % idx.size()];
      if (turn(v[ia], v[ib], v[ic]) <= 0) continue;
      bool ear = true;
      for (size_t m : idx)
        if (m != ia && m != ib && m != ic && inside(v[m], v[ia], v[ib], v[ic])) {
          ear = false;
          break;
        }
      if (!ear) continue;
      triangles.push_back({v[ia], v[ib], v[ic]});
      idx.erase(idx.begin() + long(k));
      clipped = true;
      break;
    }
    if (!clipped) break;  // self-intersecting: give up on the rest
  }
  if (idx.size() == 3) triangles.push_back({v[idx[0]], v[idx[1]], v[idx[2]]});
  return triangles;
}

// Splits a non-planar polygon into triangles; a quad along its shorter diagonal.
std::vector<std::vector<Vec3>> split_non_planar(const std::vector<Vec3>& v) {
  std::vector<std::vector<Vec3>> out;
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

ValidationReport validate_scene(Scene& scene, bool keep_overlaps) {
  ValidationReport report;
  for (const Material& m : scene.materials) check_material(m);
  std::vector<Polygon> kept;
  kept.reserve(scene.polygons.size());
  for (Polygon& polygon : scene.polygons) {
    if (polygon.material < 0 || size_t(polygon.material) >= scene.materials.size())
      throw InputError(polygon.origin + ": polygon refers to a material that does not exist");
    // Bounded before any all-pairs geometry (diameter, ear clipping) runs on it.
    if (polygon.vertices.size() > kMaxPolygonCorners)
      throw InputError(polygon.origin + ": polygon has " + std::to_string(polygon.vertices.size()) +
                       " corners; radlab accepts at most " + std::to_string(kMaxPolygonCorners) +
                       " (split it into smaller polygons)");
    for (const Vec3& p : polygon.vertices)
      if (!(std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate &&
            std::abs(p.z) <= kMaxCoordinate))
        throw InputError(polygon.origin + ": polygon has a vertex coordinate that is not finite " +
                         "or beyond 1e12 m (areas and kernels would overflow)");
    std::vector<Vec3> v = merge_repeated(polygon.vertices);
    if (degenerate(v)) {
      report.warnings.push_back(polygon.origin + ": zero-area or degenerate polygon (" +
                                std::to_string(polygon.vertices.size()) + " vertices) dropped");
      ++report.dropped;
      continue;
    }
    size_t first = 0, second = 0;
    if (self_intersecting(v, first, second))
      throw InputError(polygon.origin + ": self-intersecting polygon (its edges " +
                       std::to_string(first + 1) + " and " + std::to_string(second + 1) +
                       " cross); split it into simple polygons");
    double defect = geometry::planarity_defect(v);
    double diameter = geometry::diameter(v);
    std::vector<std::vector<Vec3>> pieces;
    if (defect > kPlanarityTolerance * diameter) {
      pieces = split_non_planar(v);
      report.warnings.push_back(
          polygon.origin + ": non-planar polygon (off its plane by " + std::to_string(defect) +
          " m, " + std::to_string(defect / diameter) + " of its size) split into triangles");
    } else if (!geometry::is_convex(v)) {
      pieces = ear_clip(v);
      report.warnings.push_back(polygon.origin +
                                ": non-convex polygon split into triangles by ear clipping");
    } else {
      polygon.vertices = std::move(v);
      kept.push_back(std::move(polygon));
      continue;
    }
    ++report.triangulated;
    for (auto& piece : pieces) {
      if (degenerate(piece)) continue;
      kept.push_back(Polygon{std::move(piece), polygon.material, polygon.origin});
    }
  }
  scene.polygons = std::move(kept);
  if (!scene.polygons.empty()) {
    report.overlaps = resolve_coincident_polygons(scene, keep_overlaps);
    for (std::string& w : report.overlaps.warnings) report.warnings.push_back(std::move(w));
  }
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
