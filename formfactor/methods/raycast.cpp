#include "formfactor/methods/raycast.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <limits>

#include "core/error.h"
#include "core/text.h"
#include "formfactor/integrate/contour_integral.h"
#include "formfactor/integrate/pair_geometry.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/matrix/fixed_sum.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/method_infos.h"
#include "scene/geometry.h"

namespace radlab {

// The work cap of every adaptive integral, one per pair (kernel evaluations beyond the starting
// cells; ~2 s here, and ~90 MB of cells per thread at most). A pair whose gap asks for many
// levels along a long edge can refine ~2^levels cells along it: once hospital.mgf's window-frame
// contacts were removed on loading (overlap.h), a build held 24 GB before it was killed (the pair
// was not identified; docs/formfactors.md). What a capped integral leaves is stated
// (row_quadrature_excess). Thin elements once had a tighter cap of their own (2e6) per starting
// cell; with one cap per pair that left F(21, 8) of
// tests/formfactor/methods/raycast_reciprocity_test.cpp 7.8% low, against 1.4% at this one.
constexpr long long kAdaptiveEvaluations = 20000000;
// A pair started from many small cells (below) works to this fraction of the tolerance: there
// the sum of the cells' error estimates fell below the true error (unit squares 0.1 mm apart:
// estimate under 1e-4 F, error 1.07e-4 F; at a quarter, 8e-7 F).
constexpr double kSplitTolerance = 0.25;
// Near pairs by contour integrals: the tolerance's share they work to (their error estimate was
// honest at every tolerance tested, tests/formfactor/integrate/contour_integral_test.cpp, and their
// cost grows only with the logarithm of the tolerance, so the margin is cheap), and their work cap
// in outer points (a pair of 16-gons starts from ~4,000).
constexpr double kContourTolerance = 0.25;
constexpr long long kContourEvaluations = 200000;
// A thin i (longer than kThinStart times the larger of its width and j's shortest edge) starts
// from at most kMaxStrips strips across its length, and a close pair from at most kMaxPieces
// triangles in all (unoccluded_over).
constexpr double kThinStart = 16.0;
constexpr int kMaxStrips = 1024;
constexpr int kMaxPieces = 32768;

// Each row's sampling variance and quadrature excess are sums of non-negative terms over its
// pairs, added in fixed point (fixed_sum.h): a one-process build adding a row's terms in column
// order and a blocked build adding each block's share of them (pair_entries, merged by
// restore_pair_block_states) give the same bits.
struct RaycastFormFactors::RowSums {
  FixedSum variance = 0, excess = 0;
  uint64_t short_pairs = 0;
  void add(double v, double e) {
    variance += to_fixed(v);
    excess += to_fixed(e);
    short_pairs += e > 0.0 ? 1 : 0;
  }
};

namespace {

// Adds `x` to the 128-bit sum in words[0] (low) and words[1] (high) from any thread: each
// addition's carry out of the low word goes to the high word, so once every thread is done the
// words hold the exact sum whatever the order.
void add_atomically(std::atomic<uint64_t>* words, FixedSum x) {
  if (x == 0) return;
  const uint64_t low = static_cast<uint64_t>(x), high = static_cast<uint64_t>(x >> 64);
  const uint64_t before = words[0].fetch_add(low, std::memory_order_relaxed);
  const uint64_t carry = before + low < before ? 1 : 0;
  if (high + carry > 0) words[1].fetch_add(high + carry, std::memory_order_relaxed);
}

}  // namespace

RaycastOptions RaycastOptions::from(ParamBag& bag) {
  RaycastOptions o;
  o.tolerance = bag.get_double("tolerance", o.tolerance);
  o.rays = int(bag.get_int("rays", o.rays, kIntMin, kIntMax));
  o.max_rays = int(bag.get_int("max_rays", std::max(o.max_rays, o.rays), kIntMin, kIntMax));
  o.seed = uint64_t(bag.get_int("seed", static_cast<long long>(o.seed), 0, kInt64Max));
  o.max_order = int(bag.get_int("max_order", o.max_order, kIntMin, kIntMax));
  o.shafts = bag.get_bool("shafts", o.shafts);
  o.validate();
  return o;
}

void RaycastOptions::validate() const {
  if (!(tolerance > 0.0 && tolerance < 1.0))
    throw UsageError("raycast: tolerance must lie in (0,1), got " + text::format_double(tolerance));
  if (rays < 1 || rays > 4096)
    throw UsageError("raycast: rays must lie in [1,4096], got " + std::to_string(rays));
  if (max_rays < rays || max_rays > 4096)
    throw UsageError("raycast: max_rays must lie in [rays,4096], got " + std::to_string(max_rays));
  if (max_order < 1 || max_order > 32)
    throw UsageError("raycast: max_order must lie in [1,32], got " + std::to_string(max_order));
}

std::string RaycastOptions::canonical() const {
  char buffer[200];
  std::snprintf(buffer, sizeof buffer,
                "max_order=%d,max_rays=%d,rays=%d,seed=%llu,shafts=%s,tolerance=%.6g", max_order,
                max_rays, rays, static_cast<unsigned long long>(seed), shafts ? "true" : "false",
                tolerance);
  return buffer;
}

FormFactorMethodInfo raycast_method_info() {
  return {"raycast",
          "Lambert point-to-polygon formula integrated over i, times an Embree visibility fraction",
          {{"tolerance", "", "relative quadrature error per pair"},
           {"rays", "", "visibility rays per pair that can be occluded"},
           {"max_rays", "", "rays for partly occluded pairs with large F (more as F grows)"},
           {"seed", "", "seed of the jittered visibility samples"},
           {"max_order", "", "largest fixed Gauss rule per axis before adaptive subdivision"},
           {"shafts", "", "shaft culling (no rays where nothing can block); false to measure it"}},
          configure_from_options<RaycastFormFactors, RaycastOptions>()};
}

RaycastFormFactors::RaycastFormFactors(const Scene& scene, const Mesh& mesh, RaycastOptions options)
    : mesh_(mesh),
      options_((options.validate(), options)),
      order_rule_(options.tolerance, options.max_order),
      plane_epsilon_(plane_epsilon(mesh)),
      visibility_(scene, mesh, options.rays, options.seed, options.shafts, options.max_rays,
                  /*importance_close_pairs=*/true) {
  radius_ = element_radii(mesh);
  row_sigma_.assign(mesh.size(), std::numeric_limits<float>::quiet_NaN());
  row_excess_.assign(mesh.size(), std::numeric_limits<float>::quiet_NaN());
  row_short_.assign(mesh.size(), 0);
  pair_sums_ = std::make_unique<std::atomic<uint64_t>[]>(mesh.size() * kRowStateBytes / 8);
}

std::vector<std::string> RaycastFormFactors::left_out() const {
  std::vector<std::string> notes = {"pairs facing away or coplanar: no quadrature, no rays"};
  for (std::string& note : visibility_.left_out()) notes.push_back(std::move(note));
  return notes;
}

// The Gauss order for the part `from` of i (the fraction `kept` of it) in front of j's plane, or 0
// when no fixed rule up to max_order suffices (Bernstein bound, polygon_integral.h).
int RaycastFormFactors::order_for(size_t i, size_t j, std::span<const Vec3> from,
                                  double kept) const {
  const double gap = glm::distance(mesh_.centroid[i], mesh_.centroid[j]) - radius_[i] - radius_[j];
  const double diameter = 2.0 * radius_[i];
  const double scale = grazing_scale(mesh_, i, j, from, kept, diameter);
  return order_rule_.order(gap, diameter, scale);
}

int RaycastFormFactors::fixed_order(size_t i, size_t j) const {
  std::vector<Vec3> from;
  mesh_.corners(i, from);
  const double kept = clip_to_front(from, mesh_.centroid[j], mesh_.normal[j], plane_epsilon_);
  return kept > 0.0 ? order_for(i, j, from, kept) : 0;
}

double RaycastFormFactors::unoccluded(size_t i, size_t j, RowCost& cost, double* error) const {
  // F^u_ij A_i = F^u_ji A_j: the pair is integrated once, over the smaller element (the lower
  // index where the areas are equal), and the other direction follows by reciprocity. The outer
  // numerical integral is the hard one: over a large element next to a small or thin one, its
  // integrand F_{dx->P_j} is peaked within the small element's size of it, which the adaptive
  // rule resolves slowly or (for a sliver, aspect 1e-6) misses (80% low, tests/
  // tests/formfactor/methods/raycast_reciprocity_test.cpp), while over the small element the large
  // one's integrand is smooth. Both rows then hold the same integral, so F^u is reciprocal to
  // rounding.
  const double ai = mesh_.area[i], aj = mesh_.area[j];
  double over = 0.0;
  if (ai > 0.0 && (aj < ai || (aj == ai && j < i))) {
    const double f = unoccluded_over(j, i, cost, &over) * (aj / ai);
    if (error) *error = over * (aj / ai);
    return f;
  }
  const double f = unoccluded_over(i, j, cost, &over);
  if (error) *error = over;
  return f;
}

namespace {

// Where the adaptive rule starts on a pair integrated over i (the part `from` kept in front of
// j's plane, its nearest corner `lowest` above that plane) towards j (`to`).
struct AdaptiveStart {
  int depth = 10;             // the rule's maximum levels
  double gap = 0.0;           // the scale the integrand varies on near j (0: i reaches j's plane)
  int split = 1;              // each fan triangle cut into split x split cells (>= 4: near pairs)
  bool thin = false;          // i starts from strips across its length
  double longest = 0.0;       // i's longest edge,
  size_t longest_edge = 0;    // from corner longest_edge to the next
  double strip_length = 0.0;  // a strip's length along it
};

AdaptiveStart plan_adaptive_start(const std::vector<Vec3>& from, const Vec3& normal_i,
                                  const std::vector<Vec3>& to, const Vec3& normal_j,
                                  double diameter, double lowest) {
  AdaptiveStart start;
  // Levels: the integrand of a pair whose nearest corner is `lowest` above j's plane varies on
  // that scale, so cells must get down to it: log2(diameter / lowest) levels and 3 more for the
  // rule's own accuracy, at least 10 (the touching case, where the global budget decides), at
  // most 30. With a fixed 10 a pair 1 mm apart stopped at cells of 1 mm, 2.4e-3 off for a
  // tolerance of 1e-4 (tests/formfactor/physical_validity_test.cpp).
  // A thin i (a sliver: width = 2 area / longest edge far below its diameter) needs the same
  // number of levels for its width: halving cells along its length leaves them as wide as i
  // until they are as short as i is wide, and where i touches j near its short edge the
  // integrand changes on that scale. A floor sliver of aspect 1e-4 touching a wall's corner
  // stopped at 10 levels, cells of 1.2e-4 for a width of 5e-5, and converged to 5.9e-4 below
  // the value (the same at tolerance 1e-7; tests/formfactor/methods/raycast_reciprocity_test.cpp).
  for (size_t k = 0; k < from.size(); ++k) {
    const double length = glm::distance(from[k], from[(k + 1) % from.size()]);
    if (length >= start.longest)  // the last of equals, as before
      start.longest = length, start.longest_edge = k;
  }
  const double width = start.longest > 0.0 ? 2.0 * geometry::area(from) / start.longest : diameter;
  const auto levels_for = [&](double scale) {
    return scale > 0.0
               ? std::clamp(int(std::ceil(std::log2(std::max(diameter / scale, 1.0)))) + 3, 10, 30)
               : 10;
  };
  start.depth = std::max(levels_for(lowest), levels_for(width));
  // A pair much closer than its size (lowest < diameter / 64): the integrand falls off within
  // ~lowest of j's outline, a layer the adaptive rule's 3x3 points on large cells never land in,
  // so it converges falsely (1 mm apart: 1.9e-3 off). Start it from cells of ~16 lowest (at most
  // 64 x 64 per fan triangle), where the layer shows in the cells' differences.
  // Pairs where i reaches j's plane (lowest 0: touching, or i standing on j's plane beside j)
  // start from 4 x 4 cells per fan triangle too: from one cell the rule's first refinement can
  // agree with it by chance and stop. A unit wall and the floor strip that stops 1 mm short of it
  // (trust_test's corner cube) came out 2.4e-3 too high for a tolerance of 1e-4 (the same at
  // 1e-3: the first estimate was accepted); from 4 x 4 cells it is within 4e-6
  // (RaycastQuadrature.TouchingPairMeetsTheTolerance).
  // (A start graded towards j's outline under one global rule took a third of the work on
  // examp1.mgf but was up to 2.6e-4 off for slivers along a wall, against a tolerance of 1e-4:
  // docs/formfactors.md, "Tried, not kept".)
  // The layer's thickness is i's distance from j, not its height above j's plane: near-coplanar
  // elements side by side (examp1.mgf's reflector strips, 0.013 rad apart and 1.2 cm from each
  // other, 7.5e-5 m above each other's planes) have an integrand that varies on the scale of
  // the 1.2 cm, and split on the 7.5e-5 m took 5.6e6 evaluations for an entry of 1e-5.
  start.gap = lowest > 0.0 ? std::max(lowest, polygon_distance(from, normal_i, to, normal_j)) : 0.0;
  start.split = start.gap > 0.0 ? int(std::min(64.0, std::ceil(diameter / (16.0 * start.gap)))) : 4;
  // A thin i beside a j with short edges: the adaptive rule does not trust a cell within its own
  // size of j until the cell is no longer than j's shortest edge (polygon_integral.cpp), and it
  // halves both sides of a cell, so cells of a thin i stay as thin as i. A 5 mm x 1.95 m face of
  // a window putty prism (office1/graz.mgf) against its neighbouring face needed nine levels,
  // 2.6e5 cells, before its shared edge was refined at all, and stopped at the work cap with a
  // stated excess of 0.27. Such an i starts from strips across its length about as long as the
  // larger of its width and j's shortest edge (at most kMaxStrips).
  double to_shortest = 1e300;
  for (size_t k = 0; k < to.size(); ++k)
    to_shortest = std::min(to_shortest, glm::distance(to[k], to[(k + 1) % to.size()]));
  start.strip_length = std::max(width, to_shortest);
  start.thin = start.longest > kThinStart * start.strip_length;
  return start;
}

// The starting cells of a near, touching or thin pair as triangles (three corners each): i's fan
// triangles, or its strips across the longest edge, each cut into parts x parts.
void starting_cells(const std::vector<Vec3>& from, const AdaptiveStart& start,
                    std::vector<Vec3>& pieces) {
  thread_local std::vector<Vec3> base;
  base.clear();
  pieces.clear();
  int parts = start.split;
  if (start.thin) {
    const size_t e = start.longest_edge;
    const Vec3 axis = glm::normalize(from[(e + 1) % from.size()] - from[e]);
    append_strip_triangles(
        from, axis,
        int(std::min(double(kMaxStrips), std::ceil(start.longest / start.strip_length))), base);
    // A close pair's strips are cut further towards cells of ~16 gaps, within kMaxPieces.
    const double wanted =
        start.gap > 0.0 ? std::ceil(start.strip_length / (16.0 * start.gap)) : 1.0;
    const double room = std::floor(std::sqrt(double(kMaxPieces) / double(base.size() / 3)));
    parts = int(std::clamp(std::min(wanted, room), 1.0, 64.0));
  } else {
    for (size_t t = 1; t + 1 < from.size(); ++t)
      base.insert(base.end(), {from[0], from[t], from[t + 1]});
  }
  for (size_t t = 0; t + 2 < base.size(); t += 3) {
    const Vec3 o = base[t], u = (base[t + 1] - o) / double(parts),
               v = (base[t + 2] - o) / double(parts);
    for (int p = 0; p < parts; ++p)
      for (int q = 0; p + q < parts; ++q) {
        pieces.insert(pieces.end(),
                      {o + double(p) * u + double(q) * v, o + double(p + 1) * u + double(q) * v,
                       o + double(p) * u + double(q + 1) * v});
        if (p + q + 1 < parts)
          pieces.insert(pieces.end(), {o + double(p + 1) * u + double(q) * v,
                                       o + double(p + 1) * u + double(q + 1) * v,
                                       o + double(p) * u + double(q + 1) * v});
      }
  }
}

}  // namespace

double RaycastFormFactors::unoccluded_over(size_t i, size_t j, RowCost& cost, double* error) const {
  *error = 0.0;
  thread_local std::vector<Vec3> from, to;
  mesh_.corners(i, from);
  mesh_.corners(j, to);
  // Integrate only over the part of i in front of j's plane (no jump in the integrand).
  double lowest = 0.0;
  const double kept =
      clip_to_front(from, mesh_.centroid[j], mesh_.normal[j], plane_epsilon_, &lowest);
  if (kept <= 0.0) return 0.0;
  const PolygonRef a{from, mesh_.normal[i]};
  const PolygonRef b{to, mesh_.normal[j]};
  const int order = order_for(i, j, from, kept);
  if (order > 0) {
    cost.kernel_evaluations +=
        uint64_t(order * order * (from.size() == 4 ? 1 : int(from.size()) - 2));
    return kept * polygon_form_factor_fixed(a, b, order);
  }
  long long evaluations = 0;
  // The floor is 1e-14 of F_ij, the result after scaling by `kept`: a sliver of i kept in front
  // of j's plane (a corner touching it) then stops at once instead of refining cells whose whole
  // contribution is below 1e-14.
  const AdaptiveStart start =
      plan_adaptive_start(from, mesh_.normal[i], to, mesh_.normal[j], 2.0 * radius_[i], lowest);
  double f = 0.0, estimated = 0.0;
  // Near and touching pairs by the contour integral (contour_integral.h): one-dimensional, ~1e3
  // points where the area rule's many starting cells below take ~1e5 (examp1.mgf:
  // docs/formfactors.md, "Near pairs by contour integrals"). The area rule integrates the pairs
  // where it does not converge within its cap.
  const auto contour = [&](ContourIntegral& c) {
    c = contour_form_factor_front(from, mesh_.centroid[i], mesh_.normal[i], to, mesh_.normal[j],
                                  mesh_.area[i], plane_epsilon_,
                                  kContourTolerance * options_.tolerance, kContourEvaluations);
    cost.kernel_evaluations += uint64_t(c.evaluations);
    return c.converged;
  };
  ContourIntegral c;
  if (start.split >= 4 || start.thin) {
    if (contour(c)) {
      *error = c.error;
      return c.form_factor;
    }
    // The pieces are the starting cells of one adaptive integral: one error budget (tolerance *
    // F^u_ij over the whole pair) and one work cap, as for a pair started from one cell.
    // Pieces of a close or touching pair are each split once first (their coarse rules can
    // agree by chance); a thin i's strips farther away need not be.
    thread_local std::vector<Vec3> pieces;
    starting_cells(from, start, pieces);
    f = polygon_integral_adaptive_triangles(
        pieces, mesh_.normal[i], b, kSplitTolerance * options_.tolerance, 1e-14 / kept, start.depth,
        &evaluations, kAdaptiveEvaluations, &estimated, /*split_every_root=*/start.split >= 4);
  } else {
    // A pair started from one cell: the area rule first, while it is cheap (it finishes within
    // kAreaRuleFirst on most such pairs); the contour integral where it does not.
    f = polygon_integral_adaptive(a, b, nullptr, options_.tolerance, 1e-14 / kept, start.depth,
                                  &evaluations, kAreaRuleFirst, &estimated);
    if (evaluations >= kAreaRuleFirst) {
      cost.kernel_evaluations += uint64_t(evaluations);
      if (contour(c)) {
        *error = c.error;
        return c.form_factor;
      }
      evaluations = 0;
      f = polygon_integral_adaptive(a, b, nullptr, options_.tolerance, 1e-14 / kept, start.depth,
                                    &evaluations, kAdaptiveEvaluations, &estimated);
    }
  }
  *error = kept * estimated;
  cost.kernel_evaluations += uint64_t(evaluations);
  return kept * f;
}

bool pair_faces(const Mesh& mesh, size_t i, size_t j, double epsilon) {
  const Vec3& ni = mesh.normal[i];
  const Vec3& nj = mesh.normal[j];
  const Vec3& ci = mesh.centroid[i];
  const Vec3& cj = mesh.centroid[j];
  bool j_in_front = false, i_in_front = false;
  for (uint32_t v : mesh.element_vertices(j))
    if (glm::dot(mesh.vertices[v] - ci, ni) > epsilon) {
      j_in_front = true;
      break;
    }
  if (!j_in_front) return false;
  for (uint32_t v : mesh.element_vertices(i))
    if (glm::dot(mesh.vertices[v] - cj, nj) > epsilon) {
      i_in_front = true;
      break;
    }
  return i_in_front;
}

double RaycastFormFactors::pair(size_t i, size_t j, RowCost& cost) const {
  double variance = 0.0, excess = 0.0;
  return pair_with_errors(i, j, cost, variance, excess);
}

double RaycastFormFactors::pair_with_errors(size_t i, size_t j, RowCost& cost, double& variance,
                                            double& excess) const {
  variance = 0.0;
  excess = 0.0;
  if (i == j) return 0.0;
  if (!pair_faces(mesh_, i, j, plane_epsilon_)) {
    ++cost.pairs_culled;
    return 0.0;
  }
  double error = 0.0;
  const double f = unoccluded(i, j, cost, &error);
  // The row-sum check allows tolerance * F^u_ij for this entry (F_ij = F^u_ij V_ij <= F^u_ij, so
  // the excess in F^u bounds the one in F); what an integral stopped short of it left is stated.
  excess = std::max(0.0, error - options_.tolerance * std::max(f, 0.0));
  if (f <= 0.0) return 0.0;
  double sigma = 0.0;
  const double v = visibility_.fraction(i, j, cost, &sigma);
  variance = (f * sigma) * (f * sigma);
  return f * v;
}

double RaycastFormFactors::unoccluded_pair(size_t i, size_t j) const {
  RowCost cost;
  if (i == j || !pair_faces(mesh_, i, j, plane_epsilon_)) return 0.0;
  return unoccluded(i, j, cost);
}

void RaycastFormFactors::row(size_t i, std::span<double> out, RowCost& cost) const {
  RowSums sums;
  for (size_t j = 0; j < out.size(); ++j) {
    double v = 0.0, e = 0.0;
    out[j] = pair_with_errors(i, j, cost, v, e);
    sums.add(v, e);
  }
  finish_row(i, sums);
}

void RaycastFormFactors::finish_row(size_t i, const RowSums& sums) const {
  // Rounded up to float, so the stated error never shrinks by storage.
  const auto up = [](double x) {
    const float rounded = float(x);
    return double(rounded) < x ? std::nextafter(rounded, 1e30f) : rounded;
  };
  row_sigma_[i] = up(std::sqrt(from_fixed(sums.variance)));
  row_excess_[i] = up(from_fixed(sums.excess));
  row_short_[i] = uint32_t(std::min<uint64_t>(sums.short_pairs, UINT32_MAX));
}

void RaycastFormFactors::unoccluded_both(size_t i, size_t j, RowCost& cost, double& f_ij,
                                         double& error_ij, double& f_ji, double& error_ji) const {
  // unoccluded(i, j) integrates over j when over_j, unoccluded(j, i) over i when over_i (the
  // same conditions as there); when the two agree on the side, one integral serves both, each
  // entry scaled by the same expression as there.
  const double ai = mesh_.area[i], aj = mesh_.area[j];
  const bool over_j = ai > 0.0 && (aj < ai || (aj == ai && j < i));
  const bool over_i = aj > 0.0 && (ai < aj || (ai == aj && i < j));
  double over = 0.0;
  if (over_j && !over_i) {
    const double u = unoccluded_over(j, i, cost, &over);
    f_ij = u * (aj / ai);
    error_ij = over * (aj / ai);
    f_ji = u;
    error_ji = over;
  } else if (!over_j && over_i) {
    const double u = unoccluded_over(i, j, cost, &over);
    f_ij = u;
    error_ij = over;
    f_ji = u * (ai / aj);
    error_ji = over * (ai / aj);
  } else {
    f_ij = unoccluded(i, j, cost, &error_ij);
    f_ji = unoccluded(j, i, cost, &error_ji);
  }
}

void RaycastFormFactors::pair_entries(size_t i, std::span<double> upper, std::span<double> lower,
                                      RowCost& cost) const {
  const size_t n = mesh_.size();
  std::atomic<uint64_t>* sums = pair_sums_.get();
  const auto add_to_row = [&](size_t row, const RowSums& s) {
    std::atomic<uint64_t>* words = sums + row * (kRowStateBytes / 8);
    add_atomically(words, s.variance);
    add_atomically(words + 2, s.excess);
    if (s.short_pairs > 0) words[4].fetch_add(s.short_pairs, std::memory_order_relaxed);
  };
  RowSums own;  // row i's share, added once at the end
  for (size_t j = i + 1; j < n; ++j) {
    // pair_with_errors(i, j) and pair_with_errors(j, i), step by step.
    upper[j] = lower[j] = 0.0;
    if (!pair_faces(mesh_, i, j, plane_epsilon_)) {
      cost.pairs_culled += 2;
      continue;
    }
    double f_ij = 0.0, error_ij = 0.0, f_ji = 0.0, error_ji = 0.0;
    unoccluded_both(i, j, cost, f_ij, error_ij, f_ji, error_ji);
    const double excess_ij = std::max(0.0, error_ij - options_.tolerance * std::max(f_ij, 0.0));
    const double excess_ji = std::max(0.0, error_ji - options_.tolerance * std::max(f_ji, 0.0));
    double variance_ij = 0.0, variance_ji = 0.0;
    if (f_ij > 0.0 || f_ji > 0.0) {
      // One visibility estimate (V_ij = V_ji, the same rays), counted for each entry that asks
      // for it, as the two rows of a one-process build count it.
      RowCost seen;
      double sigma = 0.0;
      const double v = visibility_.fraction(i, j, seen, &sigma);
      cost += seen;
      if (f_ij > 0.0 && f_ji > 0.0) {
        cost.pairs_traced += seen.pairs_traced;
        cost.pairs_unoccluded += seen.pairs_unoccluded;
      }
      if (f_ij > 0.0) {
        upper[j] = f_ij * v;
        variance_ij = (f_ij * sigma) * (f_ij * sigma);
      }
      if (f_ji > 0.0) {
        lower[j] = f_ji * v;
        variance_ji = (f_ji * sigma) * (f_ji * sigma);
      }
    }
    own.add(variance_ij, excess_ij);
    RowSums other;
    other.add(variance_ji, excess_ji);
    add_to_row(j, other);
  }
  add_to_row(i, own);
}

// The work model of pair_work, in ray-equivalents (one visibility ray's CPU time): every pair
// costs kPairUnits (its facing test, its unoccluded integral and shaft test when it faces, its
// entries written and merged), and a facing pair rays_for(i, j) more (what it casts when
// something may block it: nearly every facing pair of a building). Fitted by least squares to
// the CPU seconds of hosp.mgf's 8 blocks of 8 by pair counts (one thread each; docs/workflow.md,
// "Blocks of equal estimated work"): 0.173 us a ray-equivalent, 2.0 of them a pair, a facing
// term indistinguishable from zero; the sample's rays came within 5% of the rays the blocks
// cast (704 against 668 million in block 1, 35 against 40 million in block 8).
constexpr uint32_t kWorkSample = 16;  // every 16th pair of a row: ~2 s at soda.mgf on one core
constexpr uint64_t kPairUnits = 2;
constexpr double kSecondsPerRayEquivalent = 0.18e-6;

FormFactorMethod::PairWork RaycastFormFactors::pair_work() const {
  const size_t n = mesh_.size();
  PairWork work;
  work.row_weight.assign(n, 0);
  work.row_facing.assign(n, 0);
  work.sample = kWorkSample;
  work.unit = "ray-equivalents of every " + std::to_string(kWorkSample) + "th pair";
  work.seconds_per_unit = kSecondsPerRayEquivalent * kWorkSample;
  const bool rays = visibility_.casts_rays();
  // Each row's sum in integers, over the same pairs in the same order, whatever the threads.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      uint64_t weight = 0;
      uint32_t facing = 0;
      for (size_t j = i + 1; j < n; j += kWorkSample) {
        weight += kPairUnits;
        if (!pair_faces(mesh_, i, j, plane_epsilon_)) continue;
        ++facing;
        if (rays) weight += uint64_t(visibility_.rays_for(i, j));
      }
      work.row_weight[i] = weight;
      work.row_facing[i] = facing;
    }
  });
  return work;
}

std::vector<char> RaycastFormFactors::pair_block_state() const {
  const size_t words = mesh_.size() * (kRowStateBytes / 8);
  std::vector<uint64_t> values(words);
  for (size_t k = 0; k < words; ++k) values[k] = pair_sums_[k].load(std::memory_order_relaxed);
  std::vector<char> bytes(words * sizeof(uint64_t));
  std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

bool RaycastFormFactors::restore_pair_block_states(
    const std::vector<std::vector<char>>& states) const {
  const size_t n = mesh_.size(), words = kRowStateBytes / 8;
  for (const std::vector<char>& state : states)
    if (state.size() != n * kRowStateBytes) return false;
  std::vector<RowSums> rows(n);
  std::vector<uint64_t> values(n * words);
  for (const std::vector<char>& state : states) {
    std::memcpy(values.data(), state.data(), state.size());
    for (size_t r = 0; r < n; ++r) {
      const uint64_t* w = values.data() + r * words;
      rows[r].variance += (static_cast<FixedSum>(w[1]) << 64) | w[0];
      rows[r].excess += (static_cast<FixedSum>(w[3]) << 64) | w[2];
      rows[r].short_pairs += w[4];
    }
  }
  for (size_t r = 0; r < n; ++r) finish_row(r, rows[r]);
  return true;
}

void RaycastFormFactors::ensure_row_errors(size_t i) const {
  if (!std::isnan(row_sigma_[i]) && !std::isnan(row_excess_[i])) return;
  std::vector<double> scratch(mesh_.size());
  RowCost cost;
  row(i, scratch, cost);
}

double RaycastFormFactors::row_sampling_error(size_t i) const {
  ensure_row_errors(i);
  return double(row_sigma_[i]);
}

void RaycastFormFactors::set_row_sampling_errors(std::vector<float> sigma) const {
  if (sigma.size() == row_sigma_.size()) row_sigma_ = std::move(sigma);
}

double RaycastFormFactors::row_quadrature_excess(size_t i) const {
  ensure_row_errors(i);
  return double(row_excess_[i]);
}

double RaycastFormFactors::largest_row_quadrature_excess() const {
  double largest = 0.0;
  for (float e : row_excess_)
    if (!std::isnan(e)) largest = std::max(largest, double(e));
  return largest;
}

size_t RaycastFormFactors::pairs_short_of_tolerance() const {
  size_t pairs = 0;
  for (uint32_t count : row_short_) pairs += count;
  return pairs;
}

void RaycastFormFactors::set_row_quadrature_excesses(std::vector<float> excess) const {
  if (excess.size() == row_excess_.size()) row_excess_ = std::move(excess);
}

void save_row_sampling_errors(const RaycastFormFactors& method, const std::string& matrix_file) {
  std::vector<float> data = method.row_sampling_errors();
  const std::vector<float> excess = method.row_quadrature_excesses();
  data.insert(data.end(), excess.begin(), excess.end());
  // Best effort: without it the check recomputes rows. Bound to the matrix file's header and key,
  // with a checksum (formfactor/matrix/matrix_cache.h).
  write_matrix_side_file(matrix_file, ".sigma", data.data(), data.size() * sizeof(float));
}

bool load_row_sampling_errors(const RaycastFormFactors& method, const std::string& matrix_file,
                              size_t n) {
  // Another matrix, another size, an earlier build or a damaged file: not used, the check
  // recomputes the rows it needs.
  const auto bytes = read_matrix_side_file(matrix_file, ".sigma", 2 * n * sizeof(float));
  if (!bytes) return false;
  std::vector<float> data(2 * n);
  std::memcpy(data.data(), bytes->data(), bytes->size());
  for (float s : data)
    if (!(s >= 0.0f) && !std::isnan(s)) return false;  // negative or infinite: not ours
  method.set_row_quadrature_excesses(
      std::vector<float>(data.begin() + std::ptrdiff_t(n), data.end()));
  data.resize(n);
  method.set_row_sampling_errors(std::move(data));
  return true;
}

double RaycastFormFactors::largest_row_sampling_error() const {
  double largest = 0.0;
  for (float s : row_sigma_)
    if (!std::isnan(s)) largest = std::max(largest, double(s));
  return largest;
}

double RaycastFormFactors::stated_row_sum_error(std::string* basis) const {
  const double tolerance = options_.tolerance;
  const double sampling = largest_row_sampling_error();
  const double short_of = largest_row_quadrature_excess();
  const double error = tolerance + kRowSamplingSigmas * sampling + short_of + kFloatStorageRowError;
  if (basis) {
    char buffer[600];
    std::snprintf(buffer, sizeof buffer,
                  "raycast: quadrature tolerance %.3g + float storage 1e-7 + %g standard errors of "
                  "the row's visibility sampling (largest so far %.3g; each row is checked "
                  "against its own)",
                  tolerance, kRowSamplingSigmas, sampling);
    if (short_of > 0.0) {
      const size_t used = std::strlen(buffer);
      std::snprintf(buffer + used, sizeof buffer - used,
                    " + the row's quadrature left beyond the tolerance where an integral stopped "
                    "at its depth limit or work cap (largest %.3g, %zu pairs)",
                    short_of, pairs_short_of_tolerance());
    }
    *basis = buffer;
  }
  return error;
}

std::optional<double> RaycastFormFactors::stated_reciprocity_error() const {
  // F_ij = F^u_ij V_ij with V_ji = V_ij (the same rays), so A_i F_ij - A_j F_ji is V_ij times the
  // quadrature's defect, each F^u within `tolerance` of its exact value. A pair whose integral
  // stopped short of the tolerance has no such bound.
  if (pairs_short_of_tolerance() > 0) return std::nullopt;
  return options_.tolerance;
}

bool RaycastFormFactors::row_part(size_t i, size_t lo, size_t hi, std::span<double> out,
                                  RowCost& cost) const {
  for (size_t j = lo; j < hi; ++j) out[j] = pair(i, j, cost);
  return true;
}

}  // namespace radlab
