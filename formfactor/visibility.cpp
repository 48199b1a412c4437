#include "formfactor/visibility.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#define GLM_ENABLE_EXPERIMENTAL
#include <glm/gtx/norm.hpp>
#include <numeric>
#include <thread>

#include "core/random.h"
#include "formfactor/occlusion.h"
#include "formfactor/polygon_integral.h"
#include "formfactor/sampling.h"

namespace radlab {

double plane_epsilon(const Mesh& mesh) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Vec3& v : mesh.vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  return mesh.vertices.empty() ? 0.0 : 1e-9 * glm::length(hi - lo);
}

Visibility::Visibility(const Scene& scene, const Mesh& mesh, int rays, uint64_t seed,
                       bool shaft_culling, int max_rays)
    : mesh_(mesh),
      rays_(rays),
      max_rays_(max_rays),
      seed_(seed),
      plane_epsilon_(plane_epsilon(mesh)) {
  convex_enclosure_ = is_convex_enclosure(scene);
  if (convex_enclosure_) return;
  if (shaft_culling) shafts_ = std::make_unique<ShaftCuller>(scene, mesh, plane_epsilon_);
  embree_ = std::make_unique<EmbreeScene>(mesh);
  compute_own_polygon_margins();
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

double Visibility::fraction(size_t i, size_t j, RowCost& cost) const {
  std::atomic<uint16_t>* slot = nullptr;
  if (memo_) {
    const size_t lo = std::min(i, j), hi = std::max(i, j);
    slot = &memo_[hi * (hi - 1) / 2 + lo];
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
  const int steps = traced ? trace(i, j, rays_for(i, j), cost) : kSteps;
  if (slot) {
    slot->store(uint16_t((steps + 1) | (traced ? kTracedFlag : 0)), std::memory_order_release);
    release.slot = nullptr;
  }
  return double(steps) / kSteps;
}

void Visibility::remember_pairs(bool on) const {
  const size_t n = mesh_.size();
  if (on && n >= 2)
    memo_ = std::make_unique<std::atomic<uint16_t>[]>(n * (n - 1) / 2);  // zero: unknown
  else
    memo_.reset();
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

int Visibility::trace(size_t i, size_t j, int R, RowCost& cost) const {
  // Symmetric in i and j: the same points, the same rays, whichever row asks.
  const size_t lo = std::min(i, j), hi = std::max(i, j);
  Pcg32 rng(hash_combine(hash_combine(seed_, lo), hi));
  thread_local FacingParts parts;
  if (!facing_parts(lo, hi, parts)) return kSteps;  // no unoccluded exchange to scale (F^u = 0)
  const std::vector<Vec3>& corners_lo = parts.lo;
  const std::vector<Vec3>& corners_hi = parts.hi;
  const uint32_t skip_lo = own_polygon_to_skip(lo, parts.hi_height);
  const uint32_t skip_hi = own_polygon_to_skip(hi, parts.lo_height);
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
  int visible = 0;
  // Each ray weighs its kernel cos_lo cos_hi / r^2 (below): V = sum over unblocked rays / sum
  // over all, the ratio estimator of (integral of K V) / (integral of K) from the same points.
  const Vec3 n_lo = mesh_.normal[lo], n_hi = mesh_.normal[hi];
  const float nlx = float(n_lo.x), nly = float(n_lo.y), nlz = float(n_lo.z);
  const float nhx = float(n_hi.x), nhy = float(n_hi.y), nhz = float(n_hi.z);
  alignas(64) float weight[16];
  const float lift_lo = float(8.0 * (off_plane_[lo] + float_error_));
  const float lift_hi = float(8.0 * (off_plane_[hi] + float_error_));
  double weight_all = 0.0, weight_visible = 0.0;
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
    for (int lane = 0; lane < count; ++lane) {
      visible += blocked[lane] ? 0 : 1;
      weight_all += double(weight[lane]);
      weight_visible += blocked[lane] ? 0.0 : double(weight[lane]);
    }
  }
  cost.rays += uint64_t(R);
  // In kSteps steps (the memo's resolution), the same whichever row asks. Equal weights when
  // every kernel sample vanished (points on the planes' common line).
  const double v = weight_all > 0.0 ? weight_visible / weight_all : double(visible) / R;
  return int(std::lround(std::clamp(v, 0.0, 1.0) * kSteps));
}

}  // namespace radlab
