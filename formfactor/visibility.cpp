#include "formfactor/visibility.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
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
                       bool shaft_culling)
    : mesh_(mesh), rays_(rays), seed_(seed), plane_epsilon_(plane_epsilon(mesh)) {
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
        return double(int(known & kCountMask) - 1) / rays_;
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
  const int visible = traced ? trace(i, j, cost) : rays_;
  if (slot) {
    slot->store(uint16_t((visible + 1) | (traced ? kTracedFlag : 0)), std::memory_order_release);
    release.slot = nullptr;
  }
  return double(visible) / rays_;
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

int Visibility::trace(size_t i, size_t j, RowCost& cost) const {
  // Symmetric in i and j: the same points, the same rays, whichever row asks.
  const size_t lo = std::min(i, j), hi = std::max(i, j);
  Pcg32 rng(hash_combine(hash_combine(seed_, lo), hi));
  thread_local FacingParts parts;
  if (!facing_parts(lo, hi, parts)) return rays_;  // no unoccluded exchange to scale (F^u = 0)
  const std::vector<Vec3>& corners_lo = parts.lo;
  const std::vector<Vec3>& corners_hi = parts.hi;
  const uint32_t skip_lo = own_polygon_to_skip(lo, parts.hi_height);
  const uint32_t skip_hi = own_polygon_to_skip(hi, parts.lo_height);
  // R strata of an m x m grid on each element (all of them, in order, when R = m^2, the default
  // 16), stratum k of lo paired with stratum (a k + b) mod R of hi: a random affine permutation,
  // a odd and prime to R (any odd a when R is a power of two). The jitter of ray k comes from one
  // hash of (pair key, k): no serial generator, so the lanes vectorise.
  const int R = rays_;
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
      // Parameters along the segment: skip its two ends, where it touches i and j, by 1e-4 of
      // its length, and by at least 1e-6 m on segments shorter than 1 cm.
      const float length2 = dx * dx + dy * dy + dz * dz;
      const float eps = length2 >= 1e-4f ? 1e-4f : 1e-6f / std::sqrt(std::max(length2, 1e-30f));
      packet.t_near[lane] = eps;
      packet.t_far[lane] = 1.0f - eps;
    }
    embree_->occluded16(packet, blocked, skip_lo, skip_hi);
    for (int lane = 0; lane < count; ++lane) visible += blocked[lane] ? 0 : 1;
  }
  cost.rays += uint64_t(R);
  return visible;
}

}  // namespace radlab
