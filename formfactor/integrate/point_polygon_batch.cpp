// The batched point-to-polygon evaluator (point_polygon.h): Lambert's formula for many points
// against one polygon, in loops over the points that GCC vectorises (SSE2 in the baseline build,
// AVX2 in the build chosen at run time where the CPU has it).
//
// GCC if-converts a loop (turns its branches into selects, which vectorisation needs) only when
// it may compute both sides of every branch; with its default -ftrapping-math it may not compute
// floating-point arithmetic that the source computes on one side only, and its own passes move
// arithmetic into branches (e.g. the terms of zero-length edges, which are discarded, so the
// arithmetic that makes them is moved to the other side). No floating-point trap is ever enabled
// in this program, so this file is compiled without -ftrapping-math: the pragma changes no
// result, only what may be speculated. It comes before the includes so that every function in
// this file, fast_atan.h's included, has the same options (GCC inlines across differing
// floating-point options only in one direction). fp-contract=off: no multiply-add is fused
// unless written so (atan2_upper's polynomial in the AVX2 build), so the geometry rounds exactly
// as in the scalar path (compiled for baseline x86-64, which has no FMA) also in the AVX2 build.
// no-tree-loop-distribute-patterns: small zeroing loops stay loops instead of memset calls.
#pragma GCC optimize("no-trapping-math", "fp-contract=off", "no-tree-loop-distribute-patterns")

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <utility>

#include "formfactor/integrate/fast_atan.h"
#include "formfactor/integrate/point_polygon.h"
#include "scene/geometry.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define RADLAB_X86_DISPATCH 1
#endif

namespace radlab {
namespace {

constexpr size_t kLanes = 4;   // one AVX2 register of doubles, two SSE2 ones
constexpr size_t kBlock = 64;  // points per kernel call; a multiple of kLanes
// Polygons with more corners take the scalar path. 16: examp1.mgf's luminaire has 15-gons, and a
// clip at the points' plane adds a corner; with 8, a quarter of its quadrature points (10 M)
// went through the scalar path.
constexpr size_t kMaxCorners = 16;

// The batched sum may differ from the scalar one by a few ulp per edge term: the AVX2 build fuses
// atan2_upper's polynomial (the scalar path's is unfused), and the roundings after it differ;
// every other operation is the same, in the same order, unfused. That is up to about 5e-16 *
// sum_k |term_k| (typically a few times less: the differences have random signs), a large
// relative change where the terms cancel: for a polygon seen nearly edge-on (x close to its
// plane, a result ~1e-10 from terms ~0.1) it would be ~1e-7, for a far, small polygon (terms ~
// its angular size, the result ~ its square) ~1e-13. Where sum_k |term_k| exceeds this multiple
// of |sum|, the point's sum is recomputed with the unfused atan2_upper from the same geometry
// (the same values, bit for bit), which is exactly the scalar result; elsewhere the relative
// difference stays below ~1e-13 (tests: at most 7.5e-14). (Both paths share the cancellation
// itself: the geometry's rounding errors, which it amplifies, are the same in both. On a target
// whose scalar code fuses multiply-adds, e.g. AArch64, the recomputed results differ from the
// scalar ones by those fusions, as the others do.) On hospital.mgf 47% of the points are
// recomputed (thin strips and polygons seen edge-on); with libm's atan2, as the scalar path once
// had, that was 8% of its raycast build.
constexpr double kMaxCancellation = 300.0;

// At most kBlock points against one polygon of kCorners corners.
struct Block {
  const double* x;
  const double* y;
  const double* z;
  size_t size;  // 1..kBlock
  const Vec3* corners;
  Vec3 n;
  Vec3 polygon_normal;
  double* out;      // F for the points the kernel settles (0 for back-facing ones)
  uint8_t* scalar;  // 1 where the point must take the scalar path (clipping) instead, else 0
};

// sqrt of v[0, count), count a multiple of kLanes, v aligned to 32 bytes. Not a plain loop:
// libm's sqrt may set errno, so GCC keeps a guarded scalar call per element in any loop with
// std::sqrt and vectorises nothing (-fno-math-errno would lift that, but unlike -ftrapping-math
// it cannot be set per file or function: the builtin's attributes are fixed per compilation).
// sqrtpd rounds as sqrtsd does: the results are std::sqrt's, bit for bit.
struct SqrtBaseline {
  void operator()(double* v, size_t count) const {
#ifdef RADLAB_X86_DISPATCH
    for (size_t l = 0; l < count; l += 2) _mm_store_pd(v + l, _mm_sqrt_pd(_mm_load_pd(v + l)));
#else
    for (size_t l = 0; l < count; ++l) v[l] = std::sqrt(v[l]);
#endif
  }
};

#ifdef RADLAB_X86_DISPATCH
struct SqrtAvx2 {
  [[gnu::target("avx2")]] void operator()(double* v, size_t count) const {
    for (size_t l = 0; l < count; l += 4)
      _mm256_store_pd(v + l, _mm256_sqrt_pd(_mm256_load_pd(v + l)));
  }
};
#endif

// Lambert's sum for one block of points. The block is copied to aligned local arrays and padded
// to a multiple of kLanes with its last point (the padding's results are dropped), so no loop
// needs a scalar remainder; the edges are unrolled inside the loops over the points (kCorners is
// a constant), which gives each iteration kCorners independent chains of work. The expressions
// are point_to_polygon_form_factor's, in the same order, so with the same roundings except for
// atan2_upper's (see kMaxCancellation). Three loops: the geometry, the sqrt (above), the angles
// and terms; then the recomputation of the sums that cancel too much.
template <size_t kCorners, bool kFma, class Sqrt>
inline void lambert_block(const Block& block, Sqrt sqrt_block) {
  constexpr size_t K = kCorners;
  const size_t size = block.size, padded = (size + kLanes - 1) / kLanes * kLanes;
  const Vec3 n = block.n, pn = block.polygon_normal;
  Vec3 c[K];
  for (size_t k = 0; k < K; ++k) c[k] = block.corners[k];
  alignas(32) double px[kBlock], py[kBlock], pz[kBlock], below[kBlock];
  alignas(32) double length[K][kBlock], dot[K][kBlock], normal_part[K][kBlock];
  for (size_t l = 0; l < padded; ++l) {
    const size_t k = std::min(l, size - 1);
    px[l] = block.x[k];
    py[l] = block.y[k];
    pz[l] = block.z[k];
  }
  for (size_t l = 0; l < padded; ++l) {
    double ax[K], ay[K], az[K];
    double count = 0.0;
#pragma GCC unroll 8
    for (size_t k = 0; k < K; ++k) {
      ax[k] = c[k].x - px[l];
      ay[k] = c[k].y - py[l];
      az[k] = c[k].z - pz[l];
      // Corner k below x's tangent plane: the polygon must be clipped (the scalar path; the
      // same test as below_tangent_plane, written out so that it vectorises).
      const double height = ax[k] * n.x + ay[k] * n.y + az[k] * n.z;
      const double distance2 = ax[k] * ax[k] + ay[k] * ay[k] + az[k] * az[k];
      count += (height < 0.0 && height * height > kTangentSlack2 * distance2) ? 1.0 : 0.0;
    }
    below[l] = count;
#pragma GCC unroll 8
    for (size_t k = 0; k < K; ++k) {
      const size_t j = k + 1 < K ? k + 1 : 0;
      const double cx = ay[k] * az[j] - ay[j] * az[k], cy = az[k] * ax[j] - az[j] * ax[k],
                   cz = ax[k] * ay[j] - ax[j] * ay[k];
      length[k][l] = cx * cx + cy * cy + cz * cz;
      dot[k][l] = ax[k] * ax[j] + ay[k] * ay[j] + az[k] * az[j];
      normal_part[k][l] = n.x * cx + n.y * cy + n.z * cz;
    }
  }
  for (size_t k = 0; k < K; ++k) sqrt_block(length[k], padded);
  alignas(32) double result[kBlock], flag[kBlock];
  for (size_t l = 0; l < padded; ++l) {
    double sum = 0.0, magnitude = 0.0;
#pragma GCC unroll 8
    for (size_t k = 0; k < K; ++k) {
      // len = 0: x on the edge's line, no solid angle (the scalar path skips the edge); the
      // lane's 0/0 is computed and discarded. A NaN len is not <= 0 and passes, as there.
      const double len = length[k][l];
      const AtanReduction r = atan2_upper_reduce(len, dot[k][l]);
      const double gamma = atan2_upper_finish<kFma>(r, r.num / r.den);
      const double term = len <= 0.0 ? 0.0 : gamma * normal_part[k][l] / len;
      sum += term;
      magnitude += std::fabs(term);
    }
    const double dx = px[l] - c[0].x, dy = py[l] - c[0].y, dz = pz[l] - c[0].z;
    // x sees the polygon's back (one-sided emitters and receivers): 0, as in the scalar path.
    const bool back = dx * pn.x + dy * pn.y + dz * pn.z <= 0.0;
    const double f = std::fabs(sum);
    result[l] = back ? 0.0 : f / (2.0 * std::numbers::pi);
    // 1: the tangent plane through x cuts the polygon (the scalar path clips it first); 2: the
    // sum cancels too much to differ from the scalar one by rounding only (below).
    flag[l] = back ? 0.0 : (below[l] > 0.0 ? 1.0 : (magnitude > kMaxCancellation * f ? 2.0 : 0.0));
  }
  for (size_t l = 0; l < size; ++l) {
    if (flag[l] == 2.0) {
      // The scalar path's sum from the same geometry (the same values, bit for bit: the same
      // expressions, none fused, the unfused atan2_upper): exactly the scalar result.
      double sum = 0.0;
      for (size_t k = 0; k < K; ++k) {
        const double len = length[k][l];
        if (len <= 0.0) continue;
        sum += atan2_upper<false>(len, dot[k][l]) * normal_part[k][l] / len;
      }
      result[l] = std::abs(sum) / (2.0 * std::numbers::pi);
    }
    block.out[l] = result[l];
    block.scalar[l] = flag[l] == 1.0;
  }
}

using Kernel = void (*)(const Block&);

template <size_t kCorners>
[[gnu::flatten]] void kernel_baseline(const Block& block) {
  lambert_block<kCorners, false>(block, SqrtBaseline{});
}

#ifdef RADLAB_X86_DISPATCH
// The same source built for AVX2 and FMA (FMA only in atan2_upper's polynomial, see the pragma),
// chosen at run time; the library itself stays baseline x86-64. `flatten` inlines the kernel
// and then the AVX2 sqrt into it (the sqrt cannot be inlined into the kernel's own, untargeted
// body).
template <size_t kCorners>
[[gnu::target("avx2,fma"), gnu::flatten]] void kernel_avx2(const Block& block) {
  lambert_block<kCorners, true>(block, SqrtAvx2{});
}
#endif

// Kernels by corner count (index 3..kMaxCorners), one table per build.
template <size_t... kCorners>
constexpr std::array<Kernel, kMaxCorners + 1> baseline_kernels(std::index_sequence<kCorners...>) {
  std::array<Kernel, kMaxCorners + 1> table{};
  ((table[kCorners + 3] = kernel_baseline<kCorners + 3>), ...);
  return table;
}

#ifdef RADLAB_X86_DISPATCH
template <size_t... kCorners>
constexpr std::array<Kernel, kMaxCorners + 1> avx2_kernels(std::index_sequence<kCorners...>) {
  std::array<Kernel, kMaxCorners + 1> table{};
  ((table[kCorners + 3] = kernel_avx2<kCorners + 3>), ...);
  return table;
}
#endif

constexpr auto kBaselineKernels = baseline_kernels(std::make_index_sequence<kMaxCorners - 2>());
#ifdef RADLAB_X86_DISPATCH
constexpr auto kAvx2Kernels = avx2_kernels(std::make_index_sequence<kMaxCorners - 2>());
#endif

const std::array<Kernel, kMaxCorners + 1>& resolve(BatchKernel kernel) {
#ifdef RADLAB_X86_DISPATCH
  static const bool has_avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  if (kernel != BatchKernel::kBaseline && has_avx2) return kAvx2Kernels;
#else
  (void)kernel;
#endif
  return kBaselineKernels;
}

}  // namespace

const char* batch_kernel_name(BatchKernel kernel) {
  return &resolve(kernel) == &kBaselineKernels ? "baseline" : "avx2";
}

void point_to_polygon_form_factors(const PointBatch& points, const Vec3& n,
                                   std::span<const Vec3> polygon, const Vec3& polygon_normal,
                                   double* out, std::vector<Vec3>& scratch, BatchKernel kernel) {
  const size_t count = points.count;
  // Every point's tangent plane has the normal n, so the part of the polygon below the lowest
  // of them is below every point's and is clipped off once here, not per point: the quadrature
  // points of one element share its plane, and against a polygon crossing that plane (a floor
  // that runs on behind a small face standing on it) every point took the scalar path, a clip
  // and a scalar sum (hospital.mgf: three quarters of its points). Each point then clips what
  // remains below its own plane, if anything (below_tangent_plane), as before.
  if (count > 1 && polygon.size() >= 3) {
    size_t lowest = 0;
    double lowest_height = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < count; ++k) {
      const double height = n.x * points.x[k] + n.y * points.y[k] + n.z * points.z[k];
      if (height < lowest_height) lowest_height = height, lowest = k;
    }
    const Vec3 origin(points.x[lowest], points.y[lowest], points.z[lowest]);
    bool cut = false;
    for (const Vec3& c : polygon) cut = cut || glm::dot(c - origin, n) < 0.0;
    if (cut) {
      thread_local std::vector<Vec3> above;
      geometry::clip_to_halfspace(polygon, origin, n, above);
      if (above.size() < 3) {  // nothing of the polygon above any point's tangent plane
        std::fill(out, out + count, 0.0);
        return;
      }
      polygon = above;
    }
  }
  const size_t corners = polygon.size();
  if (corners < 3 || corners > kMaxCorners) {
    for (size_t k = 0; k < count; ++k)
      out[k] = point_to_polygon_form_factor(Vec3(points.x[k], points.y[k], points.z[k]), n, polygon,
                                            polygon_normal, scratch);
    return;
  }
  const Kernel run = resolve(kernel)[corners];
  uint8_t scalar[kBlock];
  for (size_t begin = 0; begin < count; begin += kBlock) {
    const size_t size = std::min(kBlock, count - begin);
    run({points.x + begin, points.y + begin, points.z + begin, size, polygon.data(), n,
         polygon_normal, out + begin, scalar});
    for (size_t l = 0; l < size; ++l)
      if (scalar[l]) {
        const size_t k = begin + l;
        out[k] = point_to_polygon_form_factor(Vec3(points.x[k], points.y[k], points.z[k]), n,
                                              polygon, polygon_normal, scratch);
      }
  }
}

}  // namespace radlab
