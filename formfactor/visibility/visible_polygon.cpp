#include "formfactor/visibility/visible_polygon.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <numbers>

#include "formfactor/integrate/fast_atan.h"
#include "formfactor/integrate/point_polygon.h"

namespace radlab {
namespace {

using Vec2 = glm::dvec2;

double cross2(const Vec2& a, const Vec2& b) {
  return a.x * b.y - a.y * b.x;
}

double signed_area(const Vec2* p, size_t n) {
  double twice = 0.0;
  for (size_t k = 1; k + 1 < n; ++k) twice += cross2(p[k] - p[0], p[k + 1] - p[0]);
  return 0.5 * twice;
}

// The work polygons live in VisibleScratch's vectors used as plain buffers (sizes tracked
// apart): push_back, assign and swap were a third of the time. A clip or split of n corners
// yields at most 2n (each corner kept once, each edge cut once; convex inputs give n + 1, but
// rounding may bend a polygon slightly), so each step first makes room for 2n.
template <class T>
[[gnu::noinline]] void grow(std::vector<T>& buffer, size_t n) {
  buffer.resize(std::max(n, 2 * buffer.size()));
}
template <class T>
inline T* room(std::vector<T>& buffer, size_t n) {
  if (buffer.size() < n) [[unlikely]]
    grow(buffer, n);
  return buffer.data();
}

// Which side of a plane or line a polygon lies on, from its corners' signed heights h.
enum class Side { kInside, kOutside, kBoth };

// The part of in[0, n) where h = dot(c, y) - offset >= 0: kInside when that is all of it (out
// untouched), kOutside when nothing, else kBoth with the part in out[0, count). An edge is cut
// only between a corner strictly inside and one strictly outside, so the result repeats no
// corner (Lambert's formula divides by each edge's cross product). `out` holds 2n, `h` n.
Side clip3(const Vec3* in, size_t n, const Vec3& plane, double offset, Vec3* out, size_t& count,
           double* h) {
  const Vec3 c = plane;  // a copy: the stores to h might alias it
  bool any_out = false, any_in = false;
  for (size_t k = 0; k < n; ++k) {
    h[k] = glm::dot(c, in[k]) - offset;
    any_out = any_out || h[k] < 0.0;
    any_in = any_in || h[k] > 0.0;
  }
  if (!any_out) return Side::kInside;
  if (!any_in) return Side::kOutside;
  size_t kept = 0;
  for (size_t k = 0; k < n; ++k) {
    const size_t next = k + 1 == n ? 0 : k + 1;
    const double ha = h[k], hb = h[next];
    if (ha >= 0.0) out[kept++] = in[k];
    if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0))
      out[kept++] = in[k] + (ha / (ha - hb)) * (in[next] - in[k]);
  }
  count = kept;
  return Side::kBoth;
}

// Splits the convex polygon in[0, n) by the directed line a->b: the part on its right goes to
// right[0, right_count), the part on its left to left[0, left_count). The same cutting rule as
// clip3. kInside: all of it on the left (nothing written); kOutside: all on the right (nothing
// written: the right part is `in` itself). `right` and `left` hold 2n, `h` n.
Side split2(const Vec2* in, size_t n, const Vec2& from, const Vec2& to, Vec2* right,
            size_t& right_count, Vec2* left, size_t& left_count, double* h) {
  bool any_right = false, any_left = false;
  const Vec2 a = from, e = to - from;  // copies: the stores to h might alias them
  for (size_t k = 0; k < n; ++k) {
    h[k] = cross2(e, in[k] - a);
    any_right = any_right || h[k] < 0.0;
    any_left = any_left || h[k] > 0.0;
  }
  if (!any_right) return Side::kInside;
  if (!any_left) return Side::kOutside;
  size_t l = 0, r = 0;
  for (size_t k = 0; k < n; ++k) {
    const size_t next = k + 1 == n ? 0 : k + 1;
    const double ha = h[k], hb = h[next];
    if (ha >= 0.0) left[l++] = in[k];
    if (ha <= 0.0) right[r++] = in[k];
    if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0)) {
      const Vec2 cut = in[k] + (ha / (ha - hb)) * (in[next] - in[k]);
      left[l++] = cut;
      right[r++] = cut;
    }
  }
  left_count = l;
  right_count = r;
  return Side::kBoth;
}

#if defined(__GNUC__)  // GCC's and Clang's vector extensions
// Two lanes of doubles: Lambert's edge terms two at a time. Lane-wise IEEE arithmetic with the
// operations of the scalar code in the same order, so each lane has the scalar code's bits.
using Lanes = double __attribute__((vector_size(16)));
using LaneBits = long long __attribute__((vector_size(16)));

Lanes load_lanes(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// fast_atan.h's atan2_upper (its kFma = false path) on two lanes: the same constants, the same
// operations in the same order; its selects become lane selects.
Lanes atan2_upper_lanes(Lanes y, Lanes x) {
  constexpr double kTanPi8 = 0.41421356237309503;
  constexpr double kQuarterHi = 0.7853981633974483, kQuarterLo = 3.061616997868383e-17;
  const Lanes one = {1.0, 1.0}, zero = {0.0, 0.0};
  LaneBits bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits &= LaneBits{0x7fffffffffffffffLL, 0x7fffffffffffffffLL};  // std::fabs
  Lanes ax;
  std::memcpy(&ax, &bits, sizeof ax);
  const Lanes p = y < ax ? y : ax, q = y < ax ? ax : y;
  const Lanes m = p > kTanPi8 * q ? one : zero;
  const Lanes swap = y > ax ? one : zero;
  const Lanes negative = x < zero ? one : zero;
  const Lanes swap_sign = 1.0 - 2.0 * swap, negative_sign = 1.0 - 2.0 * negative;
  const Lanes sign = swap_sign * negative_sign;
  const Lanes base = 2.0 * swap + 4.0 * negative * (1.0 - swap);
  const Lanes num = sign * (p - m * q);
  const Lanes den = q + m * p;
  const Lanes k = base + sign * m;
  const Lanes hi = k * kQuarterHi, lo = k * kQuarterLo;
  const Lanes u = num / den;
  const Lanes z = u * u, z2 = z * z, z4 = z2 * z2, z8 = z4 * z4;
  const Lanes q0 = 0.1999999999994394 * z + -0.33333333333333165;
  const Lanes q1 = 0.11111110731892658 * z + -0.14285714279191977;
  const Lanes q2 = 0.07692032790080466 * z + -0.09090896242876918;
  const Lanes q3 = 0.05845558635764282 * z + -0.06662787688935538;
  const Lanes q4 = 0.03779249553360627 * z + -0.05028691908036365;
  const Lanes r0 = q1 * z2 + q0;
  const Lanes r1 = q3 * z2 + q2;
  const Lanes r2 = -0.017606989031329887 * z2 + q4;
  const Lanes poly = r2 * z8 + (r1 * z4 + r0);
  return hi + ((u * z) * poly + u + lo);
}
#endif

// point_to_polygon_form_factor (point_polygon.cpp) with the same arithmetic in the same order,
// so the same bits, inline and two edges at a time: it was a quarter of the time. Polygons that
// dip below x's tangent plane (rare: x's own plane seldom cuts P_j) take the original, which
// clips them first; so do polygons of more than kLanesMax corners.
double lambert(const Vec3& x, const Vec3& n, const Vec3* p, size_t count, const Vec3& normal,
               std::vector<Vec3>& scratch) {
  if (glm::dot(x - p[0], normal) <= 0.0) return 0.0;
  for (size_t k = 0; k < count; ++k)
    if (below_tangent_plane(p[k] - x, n))
      return point_to_polygon_form_factor(x, n, std::span<const Vec3>(p, count), normal, scratch);
  double sum = 0.0;
#if defined(__GNUC__)
  constexpr size_t kLanesMax = 32;
  if (count <= kLanesMax) {
    // The edge vectors a_k = v_k - x as structure of arrays, a_count = a_0 and one more for the
    // odd lane of an odd count (its term is not used).
    double ax[kLanesMax + 2], ay[kLanesMax + 2], az[kLanesMax + 2];
    for (size_t k = 0; k < count; ++k) {
      const Vec3 a = p[k] - x;
      ax[k] = a.x, ay[k] = a.y, az[k] = a.z;
    }
    ax[count] = ax[0], ay[count] = ay[0], az[count] = az[0];
    ax[count + 1] = ax[1], ay[count + 1] = ay[1], az[count + 1] = az[1];
    double term[kLanesMax + 1], length[kLanesMax + 1];
    for (size_t k = 0; k < count; k += 2) {
      const Lanes a_x = load_lanes(ax + k), a_y = load_lanes(ay + k), a_z = load_lanes(az + k);
      const Lanes b_x = load_lanes(ax + k + 1), b_y = load_lanes(ay + k + 1),
                  b_z = load_lanes(az + k + 1);
      // glm::cross(a, b), glm::dot(c, c), glm::dot(a, b), glm::dot(n, c).
      const Lanes c_x = a_y * b_z - b_y * a_z;
      const Lanes c_y = a_z * b_x - b_z * a_x;
      const Lanes c_z = a_x * b_y - b_x * a_y;
      const Lanes cc = c_x * c_x + c_y * c_y + c_z * c_z;
      const Lanes len = {std::sqrt(cc[0]), std::sqrt(cc[1])};
      const Lanes ab = a_x * b_x + a_y * b_y + a_z * b_z;
      const Lanes nc = n.x * c_x + n.y * c_y + n.z * c_z;
      const Lanes t = atan2_upper_lanes(len, ab) * nc / len;
      std::memcpy(term + k, &t, sizeof t);
      std::memcpy(length + k, &len, sizeof len);
    }
    for (size_t k = 0; k < count; ++k)
      if (!(length[k] <= 0.0)) sum += term[k];  // as below
    return std::abs(sum) / (2.0 * std::numbers::pi);
  }
#endif
  const Vec3 first = p[0] - x;
  Vec3 a = first;
  for (size_t k = 0; k < count; ++k) {
    const Vec3 b = k + 1 == count ? first : p[k + 1] - x;
    const Vec3 c = glm::cross(a, b);
    const double len = glm::length(c);
    if (!(len <= 0.0))  // else x is on the edge's line: the edge subtends no solid angle
      sum += atan2_upper(len, glm::dot(a, b)) * glm::dot(n, c) / len;
    a = b;
  }
  return std::abs(sum) / (2.0 * std::numbers::pi);
}

// How far below x, as a share of x's height above P_j, an occluder may reach and still be
// projected whole (see visible()).
constexpr double kBelow = 0.9;

// P_j as visible_form_factor needs it; `flat` is null when not prepared (then it is computed
// when the first shadow falls, as most points of a pair see no shadow at all).
struct Frame {
  std::span<const Vec3> corners;
  Vec3 normal, e1, e2;
  const Vec2* flat;
  double area;
  Vec2 lo, hi;  // P_j's box in the frame (when `flat` is given)
};

double visible(const Vec3& x, const Vec3& n, const Frame& to, std::span<const Occluder> occluders,
               double epsilon, VisibleScratch& s, bool* blocked, bool* hidden) {
  if (blocked) *blocked = false;
  if (hidden) *hidden = false;
  const Vec3& to_normal = to.normal;
  const Vec3& e1 = to.e1;
  const Vec3& e2 = to.e2;
  const Vec3 origin = to.corners[0];
  const double dx = glm::dot(to_normal, x - origin);
  if (!(dx > 0.0)) return 0.0;  // behind (or in) P_j's plane: P_j shows its back
  const size_t m = to.corners.size();
  auto flat = [&](const Vec3& p) {
    return Vec2(glm::dot(p - origin, e1), glm::dot(p - origin, e2));
  };
  bool cast = false;  // some shadow larger than a sliver fell on P_j
  double area_j = 0.0;
  bool shadowed = false;
  // The cone from x over P_j: for a counter-clockwise P_j with x in front, its inside is where
  // dot(c_k, y) >= dot(c_k, x), c_k = (v_{k+1} - x) x (v_k - x); the same for every occluder.
  // Set up when the first occluder needs it (most lie well below x).
  bool coned = false;
  auto set_up_cone = [&] {
    Vec3* cone = room(s.cone, m);
    double* cone_offset = room(s.cone_offset, m);
    for (size_t k = 0; k < m; ++k) {
      cone[k] = glm::cross(to.corners[k + 1 == m ? 0 : k + 1] - x, to.corners[k] - x);
      cone_offset[k] = glm::dot(cone[k], x);
    }
    coned = true;
  };
  const double front_offset = glm::dot(to_normal, origin);
  const Vec2 x_flat = flat(x);
  // The box in P_j's frame of the cone's part above kBelow dx (x's foot and P_j shrunk about it
  // by 1 - kBelow), with a margin far above the roundings of the corners' frame coordinates.
  bool topped = false;
  Vec2 top_lo(0.0), top_hi(0.0);
  double top_margin = 0.0;
  auto set_up_top = [&] {
    Vec2 lo = to.lo, hi = to.hi;
    if (!to.flat) {
      lo = Vec2(1e300), hi = Vec2(-1e300);
      for (const Vec3& c : to.corners) lo = glm::min(lo, flat(c)), hi = glm::max(hi, flat(c));
    }
    const Vec2 a = x_flat + (1.0 - kBelow) * (lo - x_flat);
    const Vec2 b = x_flat + (1.0 - kBelow) * (hi - x_flat);
    top_lo = glm::min(x_flat, glm::min(a, b));
    top_hi = glm::max(x_flat, glm::max(a, b));
    const Vec2 span = glm::abs(hi - lo) + glm::abs(x_flat - lo);
    top_margin = 1e-9 * (span.x + span.y);
    topped = true;
  };
  // The visible pieces of P_j: pieces[first[i], first[i + 1]) for i < piece_count.
  size_t piece_count = 0;
  for (const Occluder& o : occluders) {
    // Seen edge-on from x (x in its plane): it blocks a set of directions of measure zero.
    if (std::abs(glm::dot(o.normal, x - o.corners[0])) <= epsilon) continue;
    const Vec3* poly = o.corners.data();
    size_t count = o.corners.size();
    // Heights above P_j's plane. An occluder wholly in front of P_j and well below x (at most
    // kBelow of x's height) projects stably as a whole: its shadow's corners lie at most
    // 1 / (1 - kBelow) times as far from x as its own, and the divisors keep their relative
    // accuracy. Its cut by the cone from x over P_j is then left to the subtraction in 2D, the
    // cone's planes projecting onto P_j's edge lines: that cut cost more than the rest together
    // (4 planes of the cone for each occluder; the shadow's edges along P_j's then split each
    // piece only to leave slivers).
    double* depth = room(s.depth, count);
    Vec2* shadow = room(s.shadow, 2 * count);  // first the corners in P_j's frame
    double lowest = 1e300, highest = -1e300;
    for (size_t k = 0; k < count; ++k) {
      depth[k] = glm::dot(to_normal, poly[k] - origin);
      shadow[k] = flat(poly[k]);
      lowest = std::min(lowest, depth[k]);
      highest = std::max(highest, depth[k]);
    }
    // Wholly above x: on no segment from x to P_j.
    if (lowest > dx) continue;
    bool below = lowest >= 0.0 && highest <= kBelow * dx;
    if (!below && lowest >= 0.0) {
      // Reaching higher, but perhaps only beside the cone's top: at a height above kBelow dx
      // the cone's cross-section in P_j's frame is P_j shrunk about x's foot by at most
      // 1 - kBelow, within `top`. An occluder whose box misses that loses nothing to a cut at
      // kBelow dx (one plane, not the cone's 4), and the rest is projected whole.
      if (!topped) set_up_top();
      Vec2 olo(1e300), ohi(-1e300);
      for (size_t k = 0; k < count; ++k)
        olo = glm::min(olo, shadow[k]), ohi = glm::max(ohi, shadow[k]);
      if (olo.x > top_hi.x + top_margin || olo.y > top_hi.y + top_margin ||
          ohi.x < top_lo.x - top_margin || ohi.y < top_lo.y - top_margin) {
        Vec3* out = room(s.clipped, 2 * count);
        size_t kept = 0;
        // Keeps kBelow dx - depth >= 0 (all of it above: beside the cone, it blocks nothing).
        const Side side = clip3(poly, count, -to_normal, -(kBelow * dx + front_offset), out, kept,
                                room(s.height, count));
        if (side == Side::kOutside) continue;
        if (side == Side::kBoth) {
          poly = out;
          count = kept;
          depth = room(s.depth, count);
          shadow = room(s.shadow, 2 * count);
          for (size_t k = 0; k < count; ++k) {
            depth[k] = glm::dot(to_normal, poly[k] - origin);
            shadow[k] = flat(poly[k]);
          }
          below = true;
        }
      }
    }
    if (!below) {
      if (!coned) set_up_cone();
      // The part of O in the cone from x over P_j, clipped back and forth between two buffers
      // (`poly` is the occluder's own corners until a plane cuts it).
      std::vector<Vec3>* target = &s.clipped;
      std::vector<Vec3>* spare = &s.tmp;
      auto clip = [&](const Vec3& c, double offset) {
        Vec3* out = room(*target, 2 * count);
        size_t kept = 0;
        switch (clip3(poly, count, c, offset, out, kept, room(s.height, count))) {
          case Side::kInside:
            return;
          case Side::kOutside:
            count = 0;
            return;
          case Side::kBoth:
            poly = out;
            count = kept;
            std::swap(target, spare);
            return;
        }
      };
      for (size_t k = 0; k < m && count >= 3; ++k) clip(s.cone[k], s.cone_offset[k]);
      if (count < 3) continue;
      // ... and in front of P_j's plane: on the segments from x to P_j.
      clip(to_normal, front_offset);
      if (count < 3) continue;
    }
    // Its shadow: central projection from x onto P_j's plane. In the cone (or below x) d(y) <
    // d(x) (the occluder's plane misses x), so the divisor is positive.
    shadow = room(s.shadow, count);
    const size_t ns = count;
    if (below) {  // in P_j's frame: x_flat + t (flat(y) - x_flat), t = dx / (dx - dy) <= 10
      for (size_t k = 0; k < ns; ++k)
        shadow[k] = x_flat + (dx / (dx - depth[k])) * (shadow[k] - x_flat);
    } else {
      for (size_t k = 0; k < ns; ++k) {
        const Vec3& y = poly[k];
        const double dy = glm::dot(to_normal, y - origin);
        shadow[k] = flat(x + (y - x) * (dx / (dx - dy)));
      }
    }
    double shadow_area = signed_area(shadow, ns);
    if (shadow_area < 0.0) {
      std::reverse(shadow, shadow + ns);
      shadow_area = -shadow_area;
    }
    if (!shadowed) {  // first shadow: the visible set starts as all of P_j
      Vec2* pieces = room(s.pieces, m);
      if (to.flat) {
        std::copy(to.flat, to.flat + m, pieces);
        area_j = to.area;
      } else {
        for (size_t k = 0; k < m; ++k) pieces[k] = flat(to.corners[k]);
        area_j = signed_area(pieces, m);
      }
      size_t* first = room(s.first, 2);
      first[0] = 0;
      first[1] = m;
      piece_count = 1;
      shadowed = true;
    }
    const double sliver = 1e-13 * area_j;
    if (!(shadow_area > sliver)) continue;
    // A shadow clipped to the cone falls on P_j: it is cast when larger than a sliver. A whole
    // one (below) may miss P_j: it is cast where it takes more than a sliver from a piece.
    if (!below) {
      cast = true;
      if (blocked) *blocked = true;
    }
    Vec2 lo(1e300), hi(-1e300);
    for (size_t k = 0; k < ns; ++k) lo = glm::min(lo, shadow[k]), hi = glm::max(hi, shadow[k]);
    // Every piece minus the shadow: the part outside each edge in turn, the rest going on to the
    // next edge (convex minus convex as at most |S| convex pieces). The parts are written
    // straight to the end of `next` and kept there unless they are slivers.
    size_t next_used = 0, next_count = 0;
    room(s.next_first, 1)[0] = 0;
    auto keep = [&](size_t corners) {
      next_used += corners;
      ++next_count;
      room(s.next_first, next_count + 1)[next_count] = next_used;
    };
    const Vec2* pieces = s.pieces.data();
    for (size_t piece = 0; piece < piece_count; ++piece) {
      const size_t begin = s.first[piece], size = s.first[piece + 1] - begin;
      const Vec2* p = pieces + begin;
      Vec2 plo(1e300), phi(-1e300);
      for (size_t k = 0; k < size; ++k) plo = glm::min(plo, p[k]), phi = glm::max(phi, p[k]);
      if (plo.x >= hi.x || plo.y >= hi.y || phi.x <= lo.x || phi.y <= lo.y) {  // apart
        std::copy(p, p + size, room(s.next, next_used + size) + next_used);
        keep(size);
        continue;
      }
      // The rest still to split: the piece itself, then the left parts, back and forth between
      // two buffers.
      const size_t used_before = next_used, count_before = next_count;
      const Vec2* rest = p;
      size_t rest_size = size;
      std::vector<Vec2>* left_buffer = &s.rest;
      std::vector<Vec2>* spare_buffer = &s.tmp2;
      for (size_t k = 0; k < ns && rest_size >= 3; ++k) {
        // Outside this edge (on its right): visible.
        Vec2* right = room(s.next, next_used + 2 * rest_size) + next_used;
        Vec2* left = room(*left_buffer, 2 * rest_size);
        size_t right_size = 0, left_size = 0;
        const Side side = split2(rest, rest_size, shadow[k], shadow[k + 1 == ns ? 0 : k + 1], right,
                                 right_size, left, left_size, room(s.height, rest_size));
        if (side == Side::kInside) continue;
        if (side == Side::kOutside) {
          std::copy(rest, rest + rest_size, right);
          right_size = rest_size;
          rest_size = 0;
        } else {
          rest = left;
          rest_size = left_size;
          std::swap(left_buffer, spare_buffer);
        }
        if (right_size >= 3 && signed_area(right, right_size) > sliver) keep(right_size);
      }
      if (below) {
        // What is left is the part of the piece in the shadow. At most a sliver (the shadow
        // missed the piece, or all of it lay outside some edge): the piece stays whole.
        if (rest_size >= 3 && signed_area(rest, rest_size) > sliver) {
          cast = true;
          if (blocked) *blocked = true;
        } else {
          next_used = used_before;
          next_count = count_before;
          std::copy(p, p + size, room(s.next, next_used + size) + next_used);
          keep(size);
        }
      }
    }
    s.pieces.swap(s.next);
    s.first.swap(s.next_first);
    piece_count = next_count;
    if (piece_count == 0) {  // nothing of P_j is left: fully hidden from x
      if (hidden) *hidden = true;
      return 0.0;
    }
  }
  if (!cast) return lambert(x, n, to.corners.data(), m, to_normal, s.lambert);
  double f = 0.0;
  for (size_t piece = 0; piece < piece_count; ++piece) {
    const size_t begin = s.first[piece], size = s.first[piece + 1] - begin;
    Vec3* piece3 = room(s.piece3, size);
    for (size_t k = 0; k < size; ++k) {
      const Vec2& q = s.pieces[begin + k];
      piece3[k] = origin + q.x * e1 + q.y * e2;
    }
    f += lambert(x, n, piece3, size, to_normal, s.lambert);
  }
  return f;
}

}  // namespace

void VisibleTarget::set(std::span<const Vec3> to, const Vec3& to_normal) {
  corners = to;
  normal = to_normal;
  // 2D frame of P_j's plane, right-handed about its normal (so P_j is counter-clockwise in it).
  e1 = glm::normalize(corners[1] - corners[0]);
  e2 = glm::cross(normal, e1);
  const Vec3 origin = corners[0];
  flat.resize(corners.size());
  for (size_t k = 0; k < corners.size(); ++k)
    flat[k] = Vec2(glm::dot(corners[k] - origin, e1), glm::dot(corners[k] - origin, e2));
  area = signed_area(flat.data(), flat.size());
  lo = glm::dvec2(1e300);
  hi = glm::dvec2(-1e300);
  for (const glm::dvec2& f : flat) lo = glm::min(lo, f), hi = glm::max(hi, f);
}

double visible_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> to,
                           const Vec3& to_normal, std::span<const Occluder> occluders,
                           double epsilon, VisibleScratch& scratch, bool* blocked, bool* hidden) {
  // 2D frame of P_j's plane, right-handed about its normal (so P_j is counter-clockwise in it).
  const Vec3 e1 = glm::normalize(to[1] - to[0]);
  const Frame frame{to,      to_normal, e1,        glm::cross(to_normal, e1),
                    nullptr, 0.0,       Vec2(0.0), Vec2(0.0)};
  return visible(x, n, frame, occluders, epsilon, scratch, blocked, hidden);
}

double visible_form_factor(const Vec3& x, const Vec3& n, const VisibleTarget& to,
                           std::span<const Occluder> occluders, double epsilon,
                           VisibleScratch& scratch, bool* blocked, bool* hidden) {
  const Frame frame{to.corners, to.normal, to.e1, to.e2, to.flat.data(), to.area, to.lo, to.hi};
  return visible(x, n, frame, occluders, epsilon, scratch, blocked, hidden);
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
