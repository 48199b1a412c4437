// The one visibility path of the Monte Carlo solvers (stochastic-jacobi's power propagation and
// random-walk's walks): a ray from a uniform point on a mesh element in a cosine-distributed
// direction (ray_sampler.h), its closest hit found by Embree on the run's mesh. A ray from
// element i lands on the front face of element j with probability F_ij, the element-to-element
// form factor of the discretised system, so every estimator built on it estimates that system.
//
// Also the discrete distribution over elements by power that both solvers draw sources from.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "formfactor/visibility/embree_scene.h"
#include "scene/mesh.h"

namespace radlab::monte_carlo {

class ElementRays {
 public:
  static constexpr uint32_t kMiss = 0xFFFFFFFFu;

  // `mesh` must outlive this object.
  explicit ElementRays(const Mesh& mesh);

  // The element whose front face the ray from a point on `source` meets first, or kMiss (an
  // escape, or a back face: F_ij is zero where j faces away). u[1], u[2] place the origin,
  // u[3], u[4] the direction (ray_sampler.h's kDimensions numbers; u[0] is the caller's).
  uint32_t trace(size_t source, const double* u) const { return cast(ray(source, u)); }

  // The same in two halves, for callers that make a batch of rays before casting any (their
  // random memory accesses then overlap instead of waiting on one another, and Embree takes
  // the batch in one call).
  struct Ray {
    Vec3 origin, direction;
    uint32_t polygon = 0;  // the source's
  };
  Ray ray(size_t source, const double* u) const;
  uint32_t cast(const Ray& ray) const;
  // Up to kCapacity rays, fields apart: the numbers of the directions side by side, so that
  // the batch's directions are made in one loop the compiler vectorises (the division and the
  // polynomials of cosine_direction_local two rays at a time), and Embree's stream call reads
  // the origins and directions straight from here.
  struct Batch {
    static constexpr size_t kCapacity = 64;
    uint32_t source[kCapacity];
    double u1[kCapacity], u2[kCapacity], u3[kCapacity], u4[kCapacity];
    Vec3 origin[kCapacity], direction[kCapacity];
    uint32_t polygon[kCapacity];  // the sources'
    size_t size = 0;
  };
  // Appends the ray ray(source, u) would make to `batch` (which must have room); cast() makes it.
  static void add(size_t source, const double* u, Batch& batch) {
    const size_t k = batch.size++;
    batch.source[k] = uint32_t(source);
    batch.u1[k] = u[1];
    batch.u2[k] = u[2];
    batch.u3[k] = u[3];
    batch.u4[k] = u[4];
  }
  // Makes the batch's rays (the same bits as ray()), then out[k] = cast of ray k for every k, in
  // two passes: all of Embree's closest hits first, through its stream call (rtcIntersect1M,
  // flagged incoherent: on the step's rays 1.10x the rays per second of one rtcIntersect1 call
  // each, which pays a context, a ray record and Embree's dispatch per ray; bench_monte_carlo: step
  // 0.67 -> 0.72 of raw Embree), then the checks of the elements met (own polygon, front face). The
  // checks' reads of the hit elements' records are then independent of one another and overlap;
  // after each hit in turn they stalled the next ray behind a cache miss (bench_monte_carlo).
  void cast(Batch& batch, uint32_t* out) const;
  // A hint that ray(source, ...) comes soon: its record is fetched meanwhile, every cache line
  // of it (the frame and the triangles' shares lie past the first line; fetching the first
  // alone left the ray waiting on the last one, `perf annotate`).
  void prefetch(size_t source) const {
    const char* record = reinterpret_cast<const char*>(&sources_[source]);
    for (size_t line = 0; line < sizeof(Source); line += 64) __builtin_prefetch(record + line);
  }

 private:
  // What a ray from an element needs, in one place: a ray's origin and direction then cost one
  // memory access instead of the mesh's three dependent ones (element -> corner indices ->
  // corners), which on random elements were a third of a ray's time beside Embree
  // (bench_monte_carlo). A triangle or quad as the fan (a, b, c) + (a, c, d) and the first
  // triangle's share of the area; other polygons (unsplit n-gons) go through point_on_element.
  // The frame of the cosine directions is kept too (frame_about: a division per ray otherwise),
  // and the two triangles' shares as the factors that rescale u1 within each.
  struct alignas(64) Source {  // on cache-line bounds: four lines, not five
    Vec3 a, b, c, d, normal, tangent, bitangent;
    double first_share = 1.0;   // of the area, the first triangle's
    double first_scale = 1.0;   // 1 / first_share
    double second_scale = 0.0;  // 1 / (1 - first_share), 0 without a second triangle
    uint32_t polygon = 0;
    bool fan = false;  // false: an n-gon, sampled through point_on_element
  };
  Vec3 origin(const Source& s, size_t element, double u1, double u2) const;
  // The point of a fan at triangle choice m and radius r (element_rays.cpp's fan_pick).
  static Vec3 fan_point(const Source& s, double m, double r, double u2);
  // What a hit needs of the element met, apart (one cache line, not the source's three).
  struct Target {
    Vec3 normal;
    uint32_t polygon = 0;
  };

  const Mesh& mesh_;
  std::vector<Source> sources_;
  std::vector<Target> targets_;
  std::unique_ptr<EmbreeScene> embree_;
  double t_near_ = 0.0;
};

// Elements chosen with probability weight_i / sum_k weight_k (weights >= 0): the first element
// whose cumulative weight exceeds u * total (elements of weight zero have empty intervals and are
// never chosen), found through a guide table (Chen & Asau 1974): guide[k] is where that search
// ends for u = k/n, so the search for u starts at guide[floor(u n)] and walks a step or two,
// instead of a binary search's log2 n mispredicted branches. The same element as the binary
// search, for every u.
class ElementDistribution {
 public:
  explicit ElementDistribution(std::span<const double> weights);
  double total() const { return cumulative_.empty() ? 0.0 : cumulative_.back(); }
  // The element for u in [0,1).
  size_t pick(double u) const;

 private:
  std::vector<double> cumulative_;
  std::vector<uint32_t> guide_;
};

}  // namespace radlab::monte_carlo
