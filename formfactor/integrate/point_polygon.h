// The form factor from a differential area at x (unit normal n) to a planar polygon, by
// Lambert's contour formula (Nusselt's analogue; Lambert 1760, see Howell's catalogue, B-1):
//
//   F_{dx->P} = 1/(2 pi) * sum_k  gamma_k * n . (a_k x a_{k+1}) / |a_k x a_{k+1}|
//
// with a_k = v_k - x and gamma_k the angle between a_k and a_{k+1}, taken by atan2 so it stays
// accurate for nearly parallel edges (fast_atan.h's inline atan2, within ~2.5 ulp of libm's:
// where the terms cancel, a polygon seen nearly edge-on, the relative error of the sum is that
// times sum_k |term_k| / |sum|, the same order as the one the roundings of a_k already carry).
// The formula is exact for an unoccluded polygon entirely above x's tangent plane, so the polygon
// is first clipped to that half-space. Returns 0 when x sees the polygon's back.
#pragma once

#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab {

// Whether a corner at offset `a` from x lies below x's tangent plane (unit normal n), so that the
// polygon must be clipped to the plane first. Corners within an elevation of 1e-9 rad below it
// count as on it: a corner that lies in the plane exactly (one the batched evaluator made by
// clipping the polygon to its points' common plane, or one on an edge j shares with i) is put
// above or below it at random by the roundings of its coordinates, and clipping off that sliver
// cost a clip and a scalar sum per point (with the shared clip but no slack, 55% of
// hospital.mgf's quadrature points, a fifth more time for its quadrature). Lambert's contour
// formula is the signed integral of cos over the solid angle, so a part at most 1e-9 rad below
// the plane changes F by less than (1e-9)^2: no clip needed.
constexpr double kTangentSlack = 1e-9, kTangentSlack2 = kTangentSlack * kTangentSlack;
inline bool below_tangent_plane(const Vec3& a, const Vec3& n) {
  const double height = a.x * n.x + a.y * n.y + a.z * n.z;
  return height < 0.0 && height * height > kTangentSlack2 * (a.x * a.x + a.y * a.y + a.z * a.z);
}

// `polygon_normal` is the polygon's front unit normal; `scratch` avoids allocations on hot paths.
double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> polygon,
                                    const Vec3& polygon_normal, std::vector<Vec3>& scratch);

// Points as structure of arrays: point k is (x[k], y[k], z[k]), k < count.
struct PointBatch {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
  size_t count = 0;
};

// Which code the batched evaluator runs: kBest picks the AVX2+FMA build of the kernel where the
// CPU has both and the baseline (SSE2) build otherwise; kBaseline forces the latter (tests and
// benchmarks compare both). The library itself is built for baseline x86-64.
enum class BatchKernel { kBest, kBaseline };

// The name of the kernel `kernel` resolves to on this CPU: "avx2" or "baseline".
const char* batch_kernel_name(BatchKernel kernel = BatchKernel::kBest);

// F_{dx_k -> P} for many points x_k, all with the same unit normal n, against one polygon:
// out[k] = point_to_polygon_form_factor(x_k, n, polygon, polygon_normal, ...) up to rounding
// (1e-13 relative; the same formula, geometry and inline atan2, its polynomial fused). The
// polygon is set up once and the points run four at a time through branch-free loops
// (fast_atan.h) that the compiler vectorises; polygons of 3 to 16 corners (others: the scalar
// path). The scalar path's rules are kept exactly: points that see the polygon's back get 0;
// points whose tangent plane cuts the polygon take the scalar path (which clips); points whose
// edge terms cancel so much that rounding differences could exceed ~1e-13 (a polygon seen
// nearly edge-on) get the scalar result exactly (point_polygon_batch.cpp: kMaxCancellation).
void point_to_polygon_form_factors(const PointBatch& points, const Vec3& n,
                                   std::span<const Vec3> polygon, const Vec3& polygon_normal,
                                   double* out, std::vector<Vec3>& scratch,
                                   BatchKernel kernel = BatchKernel::kBest);

}  // namespace radlab
