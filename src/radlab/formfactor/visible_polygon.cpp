#include "radlab/formfactor/visible_polygon.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "radlab/formfactor/point_polygon.h"

namespace radlab {
namespace {

using Vec2 = glm::dvec2;

double cross2(const Vec2& a, const Vec2& b) {
  return a.x * b.y - a.y * b.x;
}

double signed_area(std::span<const Vec2> p) {
  double twice = 0.0;
  for (size_t k = 1; k + 1 < p.size(); ++k) twice += cross2(p[k] - p[0], p[k + 1] - p[0]);
  return 0.5 * twice;
}

// Which side of a plane or line a polygon lies on, from its corners' signed heights h.
enum class Side { kInside, kOutside, kBoth };

// Keeps the part of `in` where h = dot(c, y) - offset >= 0 (`in` is left alone when all of it
// is inside). An edge is cut only between a corner strictly inside and one strictly outside, so
// the result repeats no corner (Lambert's formula divides by each edge's cross product).
Side clip3(std::vector<Vec3>& in, const Vec3& c, double offset, std::vector<Vec3>& out,
           std::vector<double>& h) {
  const size_t n = in.size();
  h.resize(n);
  bool any_out = false, any_in = false;
  for (size_t k = 0; k < n; ++k) {
    h[k] = glm::dot(c, in[k]) - offset;
    any_out = any_out || h[k] < 0.0;
    any_in = any_in || h[k] > 0.0;
  }
  if (!any_out) return Side::kInside;
  if (!any_in) {
    in.clear();
    return Side::kOutside;
  }
  out.clear();
  for (size_t k = 0; k < n; ++k) {
    const size_t next = k + 1 == n ? 0 : k + 1;
    const double ha = h[k], hb = h[next];
    if (ha >= 0.0) out.push_back(in[k]);
    if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0))
      out.push_back(in[k] + (ha / (ha - hb)) * (in[next] - in[k]));
  }
  in.swap(out);
  return Side::kBoth;
}

// Splits `rest` by the directed line a->b: the part on its right goes to `right`, `rest` keeps
// the part on its left. The same cutting rule as clip3. Returns where `rest` lay.
Side split2(std::vector<Vec2>& rest, const Vec2& a, const Vec2& b, std::vector<Vec2>& right,
            std::vector<Vec2>& left, std::vector<double>& h) {
  const size_t n = rest.size();
  h.resize(n);
  bool any_right = false, any_left = false;
  const Vec2 e = b - a;
  for (size_t k = 0; k < n; ++k) {
    h[k] = cross2(e, rest[k] - a);
    any_right = any_right || h[k] < 0.0;
    any_left = any_left || h[k] > 0.0;
  }
  right.clear();
  if (!any_right) return Side::kInside;
  if (!any_left) {
    right.swap(rest);
    rest.clear();
    return Side::kOutside;
  }
  left.clear();
  for (size_t k = 0; k < n; ++k) {
    const size_t next = k + 1 == n ? 0 : k + 1;
    const double ha = h[k], hb = h[next];
    if (ha >= 0.0) left.push_back(rest[k]);
    if (ha <= 0.0) right.push_back(rest[k]);
    if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0)) {
      const Vec2 cut = rest[k] + (ha / (ha - hb)) * (rest[next] - rest[k]);
      left.push_back(cut);
      right.push_back(cut);
    }
  }
  rest.swap(left);
  return Side::kBoth;
}

}  // namespace

double visible_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> to,
                           const Vec3& to_normal, std::span<const Occluder> occluders,
                           double epsilon, VisibleScratch& s, bool* blocked, bool* hidden) {
  if (blocked) *blocked = false;
  if (hidden) *hidden = false;
  bool cast = false;  // some shadow larger than a sliver fell on P_j
  const Vec3 origin = to[0];
  const double dx = glm::dot(to_normal, x - origin);
  if (!(dx > 0.0)) return 0.0;  // behind (or in) P_j's plane: P_j shows its back
  const size_t m = to.size();
  // 2D frame of P_j's plane, right-handed about its normal (so P_j is counter-clockwise in it).
  const Vec3 e1 = glm::normalize(to[1] - to[0]);
  const Vec3 e2 = glm::cross(to_normal, e1);
  auto flat = [&](const Vec3& p) {
    return Vec2(glm::dot(p - origin, e1), glm::dot(p - origin, e2));
  };
  double area_j = 0.0;
  bool shadowed = false;
  // The cone from x over P_j: for a counter-clockwise P_j with x in front, its inside is where
  // dot(c_k, y) >= dot(c_k, x), c_k = (v_{k+1} - x) x (v_k - x); the same for every occluder.
  s.cone.resize(m);
  s.cone_offset.resize(m);
  for (size_t k = 0; k < m; ++k) {
    s.cone[k] = glm::cross(to[(k + 1) % m] - x, to[k] - x);
    s.cone_offset[k] = glm::dot(s.cone[k], x);
  }
  for (const Occluder& o : occluders) {
    // Seen edge-on from x (x in its plane): it blocks a set of directions of measure zero.
    if (std::abs(glm::dot(o.normal, x - o.corners[0])) <= epsilon) continue;
    // The part of O in the cone from x over P_j.
    s.clipped.assign(o.corners.begin(), o.corners.end());
    for (size_t k = 0; k < m && s.clipped.size() >= 3; ++k)
      clip3(s.clipped, s.cone[k], s.cone_offset[k], s.tmp, s.height);
    if (s.clipped.size() < 3) continue;
    // ... and in front of P_j's plane: on the segments from x to P_j.
    clip3(s.clipped, to_normal, glm::dot(to_normal, origin), s.tmp, s.height);
    if (s.clipped.size() < 3) continue;
    // Its shadow: central projection from x onto P_j's plane. In the cone d(y) < d(x) (the
    // occluder's plane misses x), so the divisor is positive.
    s.shadow.clear();
    for (const Vec3& y : s.clipped) {
      const double dy = glm::dot(to_normal, y - origin);
      s.shadow.push_back(flat(x + (y - x) * (dx / (dx - dy))));
    }
    double shadow_area = signed_area(s.shadow);
    if (shadow_area < 0.0) {
      std::reverse(s.shadow.begin(), s.shadow.end());
      shadow_area = -shadow_area;
    }
    if (!shadowed) {  // first shadow: the visible set starts as all of P_j
      s.pieces.clear();
      for (const Vec3& v : to) s.pieces.push_back(flat(v));
      s.first.assign({0, m});
      area_j = signed_area(std::span<const Vec2>(s.pieces));
      shadowed = true;
    }
    const double sliver = 1e-13 * area_j;
    if (!(shadow_area > sliver)) continue;
    cast = true;
    if (blocked) *blocked = true;
    Vec2 lo(1e300), hi(-1e300);
    for (const Vec2& p : s.shadow) lo = glm::min(lo, p), hi = glm::max(hi, p);
    // Every piece minus the shadow: the part outside each edge in turn, the rest going on to the
    // next edge (convex minus convex as at most |S| convex pieces).
    s.next.clear();
    s.next_first.assign(1, 0);
    const size_t ns = s.shadow.size();
    for (size_t piece = 0; piece + 1 < s.first.size(); ++piece) {
      const std::span<const Vec2> p(s.pieces.data() + s.first[piece],
                                    s.first[piece + 1] - s.first[piece]);
      Vec2 plo(1e300), phi(-1e300);
      for (const Vec2& q : p) plo = glm::min(plo, q), phi = glm::max(phi, q);
      const bool apart = plo.x >= hi.x || plo.y >= hi.y || phi.x <= lo.x || phi.y <= lo.y;
      s.rest.assign(p.begin(), p.end());
      for (size_t k = 0; k < ns && !apart && s.rest.size() >= 3; ++k) {
        // Outside this edge (on its right): visible.
        split2(s.rest, s.shadow[k], s.shadow[k + 1 == ns ? 0 : k + 1], s.out, s.tmp2, s.height);
        if (s.out.size() >= 3 && signed_area(s.out) > sliver) {
          s.next.insert(s.next.end(), s.out.begin(), s.out.end());
          s.next_first.push_back(s.next.size());
        }
      }
      if (apart) {
        s.next.insert(s.next.end(), p.begin(), p.end());
        s.next_first.push_back(s.next.size());
      }
    }
    s.pieces.swap(s.next);
    s.first.swap(s.next_first);
    if (s.first.size() == 1) {  // nothing of P_j is left: fully hidden from x
      if (hidden) *hidden = true;
      return 0.0;
    }
  }
  if (!cast) return point_to_polygon_form_factor(x, n, to, to_normal, s.lambert);
  double f = 0.0;
  for (size_t piece = 0; piece + 1 < s.first.size(); ++piece) {
    s.piece3.clear();
    for (size_t k = s.first[piece]; k < s.first[piece + 1]; ++k)
      s.piece3.push_back(origin + s.pieces[k].x * e1 + s.pieces[k].y * e2);
    f += point_to_polygon_form_factor(x, n, s.piece3, to_normal, s.lambert);
  }
  return f;
}

bool separated_by_plane(const Occluder& o, std::span<const Vec3> from, std::span<const Vec3> to,
                        double epsilon) {
  double lo = 1e300, hi = -1e300;
  for (auto part : {from, to})
    for (const Vec3& p : part) {
      const double d = glm::dot(o.normal, p - o.corners[0]);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
  return hi <= epsilon || lo >= -epsilon;
}

bool hides_from_corners(const Occluder& o, std::span<const Vec3> from, const Vec3& n,
                        std::span<const Vec3> to, const Vec3& to_normal, double epsilon,
                        VisibleScratch& scratch) {
  const Occluder one[] = {o};
  for (const Vec3& x : from) {
    bool hidden = false;
    visible_form_factor(x, n, to, to_normal, one, epsilon, scratch, nullptr, &hidden);
    if (!hidden) return false;
  }
  return true;
}

}  // namespace radlab
