#include "scene/triangulate.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_face_base_2.h>
#include <CGAL/Constrained_triangulation_plus_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <cmath>
#include <deque>
#include <glm/geometric.hpp>

#include "scene/geometry.h"

namespace radlab {
namespace {

struct CornerInfo {
  int index = -1;  // the polygon's corner at this point; -1 for a point where two edges touch
};
struct FaceInfo {
  int inside = -1;  // even-odd parity; -1 until the flood fill reaches the face
};

using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<CornerInfo, Kernel>;
using FaceBase = CGAL::Constrained_triangulation_face_base_2<
    Kernel, CGAL::Triangulation_face_base_with_info_2<FaceInfo, Kernel>>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
// Exact constructions and Exact_intersections_tag: edges that touch, overlap or cross (a seam,
// a corner on another edge, a non-planar face whose projection crosses itself) are split where
// they meet at the exact meeting point. With Exact_predicates_tag (meeting points rounded to
// double) the constraint hierarchy of _plus_ below lost pieces of edges on such faces, and
// number_of_enclosing_constraints dereferenced a null list: 13 fuzz findings
// (fuzz/corpus/obj/finding_cgal_*, CGAL issues 2999, 4405, 5080 report the same). The exact
// kernel costs little here: a face has at most kMaxPolygonCorners corners.
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_intersections_tag>;
// _plus_ remembers which input edges cover each piece of an edge: the even-odd count below.
using Triangulation = CGAL::Constrained_triangulation_plus_2<Cdt>;

}  // namespace

std::vector<std::vector<Vec3>> triangulate_polygon(const std::vector<Vec3>& polygon) {
  // Axes (u, w) of the polygon's plane with u x w = n, so counter-clockwise in (x, y) is
  // counter-clockwise about the polygon's normal.
  const Vec3 n = geometry::unit_normal(polygon);
  int smallest = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n[k]) < std::abs(n[smallest])) smallest = k;
  Vec3 axis(0.0);
  axis[smallest] = 1.0;
  const Vec3 u = glm::normalize(glm::cross(axis, n));
  const Vec3 w = glm::cross(n, u);
  Vec3 origin(0.0);
  for (const Vec3& p : polygon) origin += p;
  origin /= double(polygon.size());

  Triangulation cdt;
  std::vector<Triangulation::Vertex_handle> corner(polygon.size());
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Vec3 d = polygon[i] - origin;
    corner[i] = cdt.insert(Kernel::Point_2(glm::dot(d, u), glm::dot(d, w)));
    if (corner[i]->info().index < 0) corner[i]->info().index = int(i);
  }
  // One constraint per edge (not one closed polyline), so an edge walked twice counts twice.
  for (size_t i = 0; i < polygon.size(); ++i) {
    const auto a = corner[i], b = corner[(i + 1) % polygon.size()];
    if (a != b) cdt.insert_constraint(a, b);
  }

  // Flood fill from the infinite face (outside), flipping parity across every edge covered by an
  // odd number of input edges.
  std::deque<std::pair<Triangulation::Face_handle, int>> queue{{cdt.infinite_face(), 0}};
  while (!queue.empty()) {
    const auto [face, parity] = queue.front();
    queue.pop_front();
    if (face->info().inside >= 0) continue;
    face->info().inside = parity;
    for (int e = 0; e < 3; ++e) {
      const auto next = face->neighbor(e);
      if (next->info().inside >= 0) continue;
      int covering = 0;
      if (cdt.is_constrained({face, e}))
        covering = int(
            cdt.number_of_enclosing_constraints(face->vertex(cdt.cw(e)), face->vertex(cdt.ccw(e))));
      queue.emplace_back(next, parity ^ (covering & 1));
    }
  }

  auto position = [&](Triangulation::Vertex_handle v) {
    if (v->info().index >= 0) return polygon[size_t(v->info().index)];
    return origin + CGAL::to_double(v->point().x()) * u + CGAL::to_double(v->point().y()) * w;
  };
  std::vector<std::vector<Vec3>> triangles;
  for (const auto face : cdt.finite_face_handles())
    if (face->info().inside == 1)
      triangles.push_back(
          {position(face->vertex(0)), position(face->vertex(1)), position(face->vertex(2))});
  return triangles;
}

}  // namespace radlab
