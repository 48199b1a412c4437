// Monte Carlo power propagation (power_propagation.h).
#include "solvers/monte_carlo/power_propagation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

namespace radlab::monte_carlo {

namespace {

// Rays per block: the stream fills one block's numbers, TBB traces them, the deposits are summed
// in order. 2048 rays keep the buffers at ~90 kB whatever the step's ray count: small enough to
// leave more of Embree's hierarchy in the caches (bench_monte_carlo's ratio to raw Embree: 0.565
// with 2048, 0.555 with 16384).
constexpr uint64_t kBlockRays = 2048;

// The block's rays in the order of their first number u[0] (the one that picks the source),
// to 16 bits (24 above 65,536 elements), ties in ray order: an LSD radix sort on 8-bit digits.
// As the source is the first element whose cumulative weight exceeds u[0] x total, a monotone
// function of u[0], the sources then come (nearly) in order: the cumulative weights, the
// elements' records and Embree's hierarchy around them are read in order instead of at random,
// and met again while they are still in the caches. Only the order of the rays changes, never
// their numbers: the estimate is the same sum, added in another fixed order.
void order_by_first_number(std::span<const double> u, size_t count, size_t elements,
                           std::vector<uint32_t>& order, std::vector<uint32_t>& scratch,
                           std::vector<uint32_t>& key) {
  const unsigned bits = elements <= 65536 ? 16 : 24;
  order.resize(count);
  scratch.resize(count);
  key.resize(count);
  for (size_t r = 0; r < count; ++r) {
    order[r] = uint32_t(r);
    key[r] = uint32_t(u[r * kDimensions] * double(uint32_t(1) << bits));  // u < 1: below 2^bits
  }
  for (unsigned shift = 0; shift < bits; shift += 8) {
    uint32_t start[257] = {};
    for (uint32_t r : order) ++start[((key[r] >> shift) & 0xFFu) + 1];
    for (size_t d = 1; d < 257; ++d) start[d] += start[d - 1];
    for (uint32_t r : order) scratch[start[(key[r] >> shift) & 0xFFu]++] = r;
    order.swap(scratch);
  }
}

}  // namespace

PowerPropagation::PowerPropagation(const Mesh& mesh, const Radiosity& reflectance,
                                   const ElementRays& rays)
    : mesh_(mesh), rays_(rays), channels_(size_t(reflectance.channels())) {
  // rho_jc / A_j, element after element: what a hit on j multiplies the ray's power by.
  const int channels = reflectance.channels();
  gain_.resize(mesh.size() * size_t(channels));
  for (size_t j = 0; j < mesh.size(); ++j)
    for (int c = 0; c < channels; ++c)
      gain_[j * size_t(channels) + size_t(c)] = reflectance.at(c, j) / mesh.area[j];
}

uint64_t PowerPropagation::propagate(const Radiosity& x, uint64_t rays, UniformStream& stream,
                                     uint64_t* block, Radiosity& y) const {
  const size_t n = mesh_.size();
  const int channels = x.channels();
  const size_t stride = size_t(channels);
  if (stride != channels_)
    throw std::invalid_argument("PowerPropagation: x has " + std::to_string(channels) +
                                " channels, the reflectance " + std::to_string(channels_));
  if (y.channels() == channels && y.size() == n)
    std::fill(y.raw().begin(), y.raw().end(), 0.0);  // the caller's buffer, reused
  else
    y = Radiosity(channels, n);
  // The discrete distribution over sources: |P_i| summed over channels.
  std::vector<double>& weight = scratch_.weight;
  weight.resize(n);
  for (size_t i = 0; i < n; ++i) {
    double w = 0.0;
    for (int c = 0; c < channels; ++c) w += std::abs(x.at(c, i));
    weight[i] = w * mesh_.area[i];
  }
  const ElementDistribution sources(weight);
  const double total = sources.total();
  if (!(total > 0.0) || rays == 0) return 0;
  // Per ray and channel: P_ic / (N p_i) = A_i x_ic * total / (N A_i w_i) = x_ic total / (N w_i),
  // element after element (a ray's source then costs one memory access, not one per channel).
  const double per_ray = total / double(rays);
  std::vector<double>& carried = scratch_.carried;
  carried.assign(n * stride, 0.0);
  for (size_t i = 0; i < n; ++i) {
    if (!(weight[i] > 0.0)) continue;  // never a source
    const double scale = per_ray * mesh_.area[i] / weight[i];
    for (int c = 0; c < channels; ++c) carried[i * stride + size_t(c)] = x.at(c, i) * scale;
  }
  // The deposits, element after element, each beside the element's rho / A (one cache line
  // for a hit, not two), copied into y's channels at the end.
  const size_t cell = 2 * stride;
  std::vector<double>& received = scratch_.received;
  received.assign(n * cell, 0.0);
  for (size_t j = 0; j < n; ++j) std::copy_n(&gain_[j * stride], stride, &received[j * cell]);

  std::vector<double>& u = scratch_.u;
  std::vector<uint32_t>&order = scratch_.order, &scratch = scratch_.scratch, &key = scratch_.key;
  std::vector<uint32_t>&sorted_source = scratch_.sorted_source, &hit = scratch_.hit;
  for (uint64_t first = 0; first < rays; first += kBlockRays) {
    const size_t count = size_t(std::min(kBlockRays, rays - first));
    u.resize(count * kDimensions);
    sorted_source.resize(count);
    hit.resize(count);
    stream.fill((*block)++, u);
    order_by_first_number(u, count, n, order, scratch, key);
    // The rays' sources in that order.
    for (size_t k = 0; k < count; ++k)
      sorted_source[k] = uint32_t(sources.pick(u[size_t(order[k]) * kDimensions]));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const auto& range) {
      // In batches made before any is cast (element_rays.h's batch cast).
      constexpr size_t kBatch = ElementRays::Batch::kCapacity;
      ElementRays::Batch batch;
      for (size_t k = range.begin(); k < range.end(); k += kBatch) {
        const size_t size = std::min(kBatch, range.end() - k);
        batch.size = 0;
        for (size_t b = 0; b < size; ++b) {
          // The record of the source 8 rays on is fetched while this ray is made.
          if (k + b + 8 < range.end()) rays_.prefetch(sorted_source[k + b + 8]);
          ElementRays::add(sorted_source[k + b], &u[size_t(order[k + b]) * kDimensions], batch);
        }
        rays_.cast(batch, &hit[k]);
      }
    });
    for (size_t k = 0; k < count; ++k) {
      // The record of the element met 8 rays on is fetched while this ray deposits (the hits
      // are scattered: the deposit waited on a cache miss, `perf annotate`).
      if (k + 8 < count && hit[k + 8] != ElementRays::kMiss)
        __builtin_prefetch(&received[size_t(hit[k + 8]) * cell]);
      if (hit[k] == ElementRays::kMiss) continue;
      const double* from = &carried[size_t(sorted_source[k]) * stride];
      double* to = &received[size_t(hit[k]) * cell];
      for (size_t c = 0; c < stride; ++c) to[stride + c] += to[c] * from[c];
    }
  }
  for (size_t j = 0; j < n; ++j)
    for (int c = 0; c < channels; ++c) y.at(c, j) = received[j * cell + stride + size_t(c)];
  return rays;
}

uint64_t PowerPropagation::landing_fraction(uint64_t rays_per_element, UniformStream& stream,
                                            uint64_t* block, std::vector<double>& out) const {
  const size_t n = mesh_.size();
  out.assign(n, 0.0);
  std::vector<double> u(rays_per_element * kDimensions);
  std::vector<uint8_t> landed(rays_per_element);
  for (size_t i = 0; i < n; ++i) {
    stream.fill((*block)++, u);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays_per_element, 256), [&](const auto& range) {
      for (size_t r = range.begin(); r != range.end(); ++r)
        landed[r] = rays_.trace(i, &u[r * kDimensions]) != ElementRays::kMiss ? 1 : 0;
    });
    size_t count = 0;
    for (uint8_t l : landed) count += l;
    out[i] = double(count) / double(rays_per_element);
  }
  return rays_per_element * n;
}

}  // namespace radlab::monte_carlo
