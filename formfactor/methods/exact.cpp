#include "formfactor/methods/exact.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <glm/geometric.hpp>
#include <limits>
#include <optional>

#include "core/error.h"
#include "core/log.h"
#include "core/text.h"
#include "formfactor/integrate/contour_integral.h"
#include "formfactor/integrate/pair_geometry.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/integrate/quadrature.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/method_infos.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/occlusion.h"
#include "formfactor/visibility/shaft.h"
#include "formfactor/visibility/visible_polygon.h"
#include "scene/geometry.h"

namespace radlab {

// The work cap of an unoccluded pair's adaptive integral (kernel evaluations, ~2 s here; the
// cells it keeps stay below ~300 MB a thread), raycast's cap. Without one, a pair that cannot
// show it meets the tolerance refines until max_depth, 4^16 cells a root: examp1.mgf's
// near-coplanar reflector strips at tolerance 1e-9 ran for minutes and grew to gigabytes
// before the adaptive rule's running error sum was made afresh now and then
// (polygon_integral.cpp; docs/formfactors.md, "Work cap on unoccluded pairs"). What a capped
// pair leaves is stated (record_excess).
constexpr long long kUnoccludedEvaluations = 20000000;
// The contour integral's cap for a near pair (outer points; a pair of 16-gons starts from
// ~4,000, and at 1e-10 most pairs converge within a few times that).
constexpr long long kContourEvaluations = 400000;

ExactOptions ExactOptions::from(ParamBag& bag) {
  ExactOptions o;
  o.tolerance = bag.get_double("tolerance", o.tolerance);
  o.max_depth = int(bag.get_int("max_depth", o.max_depth, kIntMin, kIntMax));
  const std::string visibility = bag.get_choice("visibility", "refuse", {"refuse", "rays", "clip"});
  o.visibility_rays = visibility == "rays";
  o.visibility_clip = visibility == "clip";
  // Every key is read, whatever the mode (so that the registry lists each with its default);
  // one given for another mode is refused.
  if (!o.visibility_rays && (bag.has("rays") || bag.has("seed")))
    throw UsageError(
        "exact: 'rays' and 'seed' apply only with visibility=rays (visibility=clip "
        "samples nothing)");
  if (!o.visibility_clip && bag.has("max_evaluations"))
    throw UsageError("exact: 'max_evaluations' applies only with visibility=clip");
  o.rays = int(bag.get_int("rays", o.rays, kIntMin, kIntMax));
  o.seed = uint64_t(bag.get_int("seed", static_cast<long long>(o.seed), 0, kInt64Max));
  o.max_evaluations = bag.get_int("max_evaluations", o.max_evaluations, kIntMin, kInt64Max);
  o.validate();
  return o;
}

void ExactOptions::validate() const {
  if (!(tolerance >= 1e-15 && tolerance < 1.0))
    throw UsageError("exact: tolerance must lie in [1e-15,1), got " +
                     text::format_double(tolerance));
  if (max_depth < 1 || max_depth > 24)
    throw UsageError("exact: max_depth must lie in [1,24], got " + std::to_string(max_depth));
  if (visibility_rays && visibility_clip)
    throw UsageError("exact: visibility is either rays or clip, not both");
  if (rays < 1 || rays > 4096)
    throw UsageError("exact: rays must lie in [1,4096], got " + std::to_string(rays));
  // Below one root cell's split (4 children x 9 points) the rule could not even start.
  if (max_evaluations < 100)
    throw UsageError("exact: max_evaluations must be at least 100, got " +
                     std::to_string(max_evaluations));
}

std::string ExactOptions::canonical() const {
  char buffer[200];
  if (visibility_rays)
    std::snprintf(buffer, sizeof buffer,
                  "max_depth=%d,rays=%d,seed=%llu,tolerance=%.6g,visibility=rays", max_depth, rays,
                  static_cast<unsigned long long>(seed), tolerance);
  else if (visibility_clip)
    std::snprintf(buffer, sizeof buffer,
                  "max_depth=%d,max_evaluations=%lld,tolerance=%.6g,visibility=clip", max_depth,
                  max_evaluations, tolerance);
  else
    std::snprintf(buffer, sizeof buffer, "max_depth=%d,tolerance=%.6g,visibility=refuse", max_depth,
                  tolerance);
  return buffer;
}

FormFactorMethodInfo exact_method_info() {
  return {"exact",
          "form factors to ~1e-9 by adaptive quadrature of Lambert's formula; refuses scenes that "
          "can occlude unless visibility=clip (exact shadows) or rays",
          {{"tolerance", "", "relative quadrature error per pair"},
           {"max_depth", "", "subdivision levels of the adaptive rule"},
           {"visibility", "",
            "refuse: exit 3 if anything can occlude; rays: multiply by raycast V; clip: clip j by "
            "the occluders' shadows at every quadrature point (deterministic)"},
           {"rays", "", "visibility rays per pair that may be blocked (visibility=rays only)"},
           {"seed", "", "seed of the visibility points (visibility=rays only)"},
           {"max_evaluations", "",
            "evaluations per occluded pair before it stops short of the tolerance and states its "
            "remaining error (visibility=clip only)"}},
          configure_from_options<ExactFormFactors, ExactOptions>()};
}

ExactFormFactors::ExactFormFactors(const Scene& scene, const Mesh& mesh, ExactOptions options)
    : scene_(scene),
      mesh_(mesh),
      options_((options.validate(), options)),
      order_rule_(options_.tolerance, kMaxFixedOrder),
      element_rules_(mesh) {
  plane_epsilon_ = plane_epsilon(mesh);
  radius_ = element_radii(mesh);
  corner_.reserve(mesh.vertex_index.size());
  for (uint32_t v : mesh.vertex_index) corner_.push_back(mesh.vertices[v]);
  row_excess_.assign(mesh.size(), 0);
  if (is_convex_enclosure(scene)) {
    nothing_occludes_ = true;
    return;
  }
  if (options_.visibility_rays) {
    visibility_ = std::make_unique<Visibility>(scene, mesh, options_.rays, options_.seed, true);
    return;
  }
  if (options_.visibility_clip) {
    shafts_ = std::make_unique<ShaftCuller>(scene, mesh, plane_epsilon_);
    occluder_normal_.reserve(scene.polygons.size());
    for (const Polygon& p : scene.polygons)
      occluder_normal_.push_back(geometry::unit_normal(p.vertices));
    return;
  }
  // Every facing pair must have an empty shaft; the first that does not is named.
  ShaftCuller shafts(scene, mesh, plane_epsilon_);
  for (size_t i = 0; i < mesh.size(); ++i)
    for (size_t j = i + 1; j < mesh.size(); ++j) {
      if (!pair_faces(mesh, i, j, plane_epsilon_)) continue;
      const int64_t blocker = shafts.first_blocker(i, j);
      if (blocker < 0) continue;
      auto element = [&](size_t e) {
        return std::to_string(e) + " (" + scene.polygons[mesh.polygon[e]].origin + ")";
      };
      throw InputError(
          "form factors 'exact': the scene can occlude (it is not a convex enclosure, and "
          "polygon " +
          std::to_string(blocker) + " (" + scene.polygons[size_t(blocker)].origin +
          ") may block elements " + element(i) + " and " + element(j) +
          "); the method computes unoccluded form factors only. Use --ff-set visibility=rays to "
          "multiply by a raycast visibility fraction, or another method (raycast, hemicube)");
    }
  nothing_occludes_ = true;
}

ExactFormFactors::~ExactFormFactors() = default;

std::vector<std::string> ExactFormFactors::left_out() const {
  std::vector<std::string> notes = {"pairs facing away or coplanar: no quadrature"};
  if (visibility_) {
    for (std::string& note : visibility_->left_out()) notes.push_back(std::move(note));
  } else if (shafts_) {
    notes.push_back(
        "visibility by clipping: pairs whose shaft no polygon reaches get no clipping "
        "(pairs_unoccluded); the others clip P_j by the shadows of the polygons in their shaft at "
        "every quadrature point (pairs_traced, rays 0), at most max_evaluations points a pair "
        "(" +
        std::to_string(pairs_capped()) +
        " pairs stopped short of the tolerance so far; their remaining error is in the stated "
        "error)");
  } else {
    notes.push_back(is_convex_enclosure(scene_)
                        ? "visibility: none (the scene is a convex enclosure, nothing can occlude)"
                        : "visibility: none (shaft culling proved every pair unoccluded)");
  }
  if (!shafts_ && pairs_capped() > 0)
    notes.push_back(std::to_string(pairs_capped()) +
                    " pairs stopped short of the tolerance (at most " +
                    std::to_string(kUnoccludedEvaluations) +
                    " evaluations a pair, or max_depth); their remaining error is in the stated "
                    "error");
  return notes;
}

double ExactFormFactors::pair(size_t i, size_t j, RowCost& cost) const {
  if (integrates_from(mesh_, i, j)) return pair_integral(i, j, cost);
  return reciprocal(pair_integral(j, i, cost), mesh_.area[j], mesh_.area[i]);
}

namespace {

// The heights of N corners (N known at compile time: quads, triangles), all computed before any is
// compared, so no comparison waits for the next dot product; then the least and greatest in
// corner order (the same values as one pass) and the flags without branches.
template <size_t N>
[[gnu::always_inline]] inline void corner_heights(const Vec3* corners, const Vec3& point,
                                                  const Vec3& normal, double epsilon, double& low,
                                                  double& high, bool& front, bool& behind) {
  double height[N];
  for (size_t k = 0; k < N; ++k) height[k] = glm::dot(corners[k] - point, normal);
  for (size_t k = 0; k < N; ++k) {
    low = std::min(low, height[k]);
    high = std::max(high, height[k]);
    front = front | (height[k] > epsilon);
    behind = behind | (height[k] < -epsilon);
  }
}

}  // namespace

[[gnu::always_inline]] inline ExactFormFactors::Heights ExactFormFactors::heights(
    std::span<const Vec3> corners, const Vec3& point, const Vec3& normal) const {
  Heights h;
  const Vec3* c = corners.data();
  if (corners.size() == 4) {
    corner_heights<4>(c, point, normal, plane_epsilon_, h.low, h.high, h.front, h.behind);
  } else if (corners.size() == 3) {
    corner_heights<3>(c, point, normal, plane_epsilon_, h.low, h.high, h.front, h.behind);
  } else {
    for (size_t k = 0; k < corners.size(); ++k)
      corner_heights<1>(c + k, point, normal, plane_epsilon_, h.low, h.high, h.front, h.behind);
  }
  return h;
}

double ExactFormFactors::pair_integral(size_t i, size_t j, RowCost& cost, bool may_turn) const {
  if (i == j) return 0.0;
  // pair_faces (raycast.h) from the heights unoccluded() needs anyway: the same dots.
  const std::span<const Vec3> to = corners(j);
  const Heights j_heights = heights(to, mesh_.centroid[i], mesh_.normal[i]);
  const Heights i_heights =
      j_heights.front ? heights(corners(i), mesh_.centroid[j], mesh_.normal[j]) : Heights{};
  if (!j_heights.front || !i_heights.front) {
    ++cost.pairs_culled;
    return 0.0;
  }
  // Integrate only over the part of i in front of j's plane (no jump in the integrand). With no
  // corner behind it, clip_to_front keeps all of i: i's corners are used in place.
  std::span<const Vec3> from = corners(i);
  double kept = 1.0;
  thread_local std::vector<Vec3> clipped;
  if (i_heights.behind) {
    clipped.assign(from.begin(), from.end());
    kept = clip_to_front(clipped, mesh_.centroid[j], mesh_.normal[j], plane_epsilon_);
    if (kept <= 0.0) return 0.0;
    from = clipped;
  }
  if (shafts_) {
    thread_local std::vector<Occluder> occluders;
    pair_occluders(i, j, from, to, occluders);
    if (!occluders.empty()) {
      ++cost.pairs_traced;
      // Integrate over the side farther from the occluders (View3D's choice of projection,
      // Walton 2002): seen from a point near an occluder its shadow on the far element is
      // magnified and sweeps across that element's edges as the point moves, so the visible
      // part's form factor has kinks inside the integration domain (every one costs the adaptive
      // rule refinement to resolve); from the far side the shadow moves slowly and mostly stays
      // within the near element. On the box-in-a-room of docs/formfactors.md a floor element
      // under the box's edge integrated from the floor stopped 6.3e-3 off at 189 evaluations;
      // from the ceiling its smooth integrand converges with the first split. Only between
      // elements of about the same size: over a much larger element (a Cornell block face seen
      // from the 11x larger ceiling) the narrow band from which the small one is half hidden is
      // the feature to resolve, and the rule stopped at its work cap stated 7x less error than it
      // made (clip_contact_test).
      //
      // j's part in front of i's plane and its own candidates, for integrating over j, set up
      // when first needed. False when none is left (every candidate's plane separates j's front
      // part from i): then only the usual side, whose integral is as good, only slower.
      thread_local std::vector<Vec3> j_front;
      thread_local std::vector<Occluder> reversed;
      double j_kept = 0.0;
      std::optional<bool> j_ready;
      auto j_possible = [&] {
        if (!j_ready) {
          j_front.assign(to.begin(), to.end());
          j_kept = clip_to_front(j_front, mesh_.centroid[i], mesh_.normal[i], plane_epsilon_);
          if (j_kept > 0.0) pair_occluders(j, i, j_front, corners(i), reversed);
          j_ready = j_kept > 0.0 && !reversed.empty();
        }
        return *j_ready;
      };
      auto over_i = [&](bool& proven) {
        return occluded(i, j, from, to, kept, occluders, cost, &proven);
      };
      auto over_j = [&](bool& proven) {
        return reciprocal(occluded(j, i, j_front, corners(i), j_kept, reversed, cost, &proven),
                          mesh_.area[j], mesh_.area[i]);
      };
      const bool turned = may_turn && mesh_.area[j] <= 2.0 * mesh_.area[i] &&
                          occluders_nearer(i, j, occluders) && j_possible();
      bool proven = false;
      double f = turned ? over_j(proven) : over_i(proven);
      // A zero no single occluder proves (the corner test) may be a visible part too small for
      // any of the rule's points to fall in it: on the Cornell box (3 x 3) a wall triangle sees
      // the ceiling from 0.3% of its area, near one corner (a brute force of 160,000 points:
      // F = 7.6e-6), and all 189 points over the triangle saw nothing, so the rule stated 0 as
      // converged. The other side's points see it from a broad region. So the other side is
      // probed (36 points); where any sees past the occluders, its integral is taken.
      if (may_turn && f == 0.0 && !proven) {
        if (turned) {
          if (any_visible(i, j, from, to, occluders, cost)) f = over_i(proven);
        } else if (j_possible() && any_visible(j, i, j_front, corners(i), reversed, cost)) {
          f = over_j(proven);
        }
      }
      return f;
    }
  }
  const Heights from_heights =
      i_heights.behind ? heights(from, mesh_.centroid[j], mesh_.normal[j]) : i_heights;
  const double f = unoccluded(i, j, from, to, kept, from_heights, j_heights, cost);
  if (f <= 0.0) return 0.0;
  if (visibility_) return f * visibility_->fraction(i, j, cost);
  ++cost.pairs_unoccluded;
  return f;
}

[[gnu::always_inline]] inline double ExactFormFactors::double_area_scale(size_t i, size_t j,
                                                                         double i_high,
                                                                         double j_high,
                                                                         double& both) const {
  // unoccluded()'s height_mean and slope (kept == 1: the centre is i's centroid).
  const double height_mean = glm::dot(mesh_.centroid[i] - mesh_.centroid[j], mesh_.normal[j]);
  const double slope = glm::length(glm::cross(mesh_.normal[i], mesh_.normal[j]));
  both = 2.0 * std::max(radius_[i], radius_[j]);
  const double h_mean = glm::dot(mesh_.centroid[j] - mesh_.centroid[i], mesh_.normal[i]);
  return std::min(height_mean / (i_high + slope * both), h_mean / (j_high + slope * both));
}

[[gnu::always_inline]] inline int ExactFormFactors::double_area_order(
    size_t i, size_t j, double gap, const Heights& i_heights, const Heights& j_heights) const {
  double both = 0.0;
  const double scale = double_area_scale(i, j, i_heights.high, j_heights.high, both);
  return order_rule_.order(gap, both, scale);
}

// Field by field into `out`: a whole struct built aside and copied was read back in 16-byte
// pieces just after its 8-byte stores, a store-forwarding stall on every pair.
[[gnu::always_inline]] inline void ExactFormFactors::double_area_rules(size_t i, size_t j, int m,
                                                                       DoubleAreaRules& out) const {
  const int order = std::max(2, m);
  out.a_high = element_rules_.rule(i, order);
  out.b_high = element_rules_.rule(j, order);
  out.a_low = element_rules_.rule(i, order - 1);
  out.b_low = element_rules_.rule(j, order - 1);
  out.n_i = mesh_.normal[i];
  out.n_j = mesh_.normal[j];
  out.area_j = mesh_.area[j];
}

void ExactFormFactors::upper_row(size_t i, std::span<double> out, RowCost& cost) const {
  const size_t n = mesh_.size();
  auto general = [&](size_t j) {
    return integrates_from(mesh_, i, j) ? pair_integral(i, j, cost) : pair_integral(j, i, cost);
  };
  if (shafts_ || visibility_) {  // every pair may need clipping or rays
    for (size_t j = i + 1; j < n; ++j) out[j] = general(j);
    return;
  }
  // pair_integral's steps up to the double-area order in three passes over the batch, each
  // short and without a chain from one pair to the next: the heights (culled: -1; clipped, or
  // touching a plane: 0, pair_integral decides), then gap and height scale (two square roots,
  // three divisions), then the order.
  constexpr size_t kBatch = 8;
  size_t a[kBatch], b[kBatch];
  int order[kBatch];
  double a_high[kBatch], b_high[kBatch], gap[kBatch], both[kBatch], scale[kBatch];
  for (size_t first = i + 1; first < n; first += kBatch) {
    const size_t count = std::min(kBatch, n - first);
    for (size_t k = 0; k < count; ++k) {
      const size_t j = first + k;
      const bool from_i = integrates_from(mesh_, i, j);
      a[k] = from_i ? i : j;
      b[k] = from_i ? j : i;
      const Heights b_heights = heights(corners(b[k]), mesh_.centroid[a[k]], mesh_.normal[a[k]]);
      const Heights a_heights =
          b_heights.front ? heights(corners(a[k]), mesh_.centroid[b[k]], mesh_.normal[b[k]])
                          : Heights{};
      a_high[k] = a_heights.high;
      b_high[k] = b_heights.high;
      order[k] =
          !(b_heights.front && a_heights.front) ? -1
          : !a_heights.behind && a_heights.low > plane_epsilon_ && b_heights.low > plane_epsilon_
              ? 1
              : 0;
    }
    // Only the pairs still in question (culled ones are a sixth of a closed room's).
    size_t open[kBatch], opened = 0;
    for (size_t k = 0; k < count; ++k)
      if (order[k] > 0) open[opened++] = k;
    for (size_t o = 0; o < opened; ++o) {
      const size_t k = open[o];
      // unoccluded()'s gap
      gap[k] =
          glm::distance(mesh_.centroid[a[k]], mesh_.centroid[b[k]]) - radius_[a[k]] - radius_[b[k]];
      scale[k] = double_area_scale(a[k], b[k], a_high[k], b_high[k], both[k]);
    }
    for (size_t o = 0; o < opened; ++o) {
      const size_t k = open[o];
      order[k] = gap[k] > 0.0 ? order_rule_.order(gap[k], both[k], scale[k]) : 0;
    }
    // The double-area rules of the candidates, two pairs at a time.
    size_t candidate[kBatch], candidates = 0;
    for (size_t k = 0; k < count; ++k)
      if (order[k] > 0 && order[k] <= ElementRules::kMaxOrder) candidate[candidates++] = k;
    DoubleAreaRules rules[kBatch];
    DoubleAreaPair f[kBatch];
    for (size_t c = 0; c < candidates; ++c) {
      const size_t k = candidate[c];
      double_area_rules(a[k], b[k], order[k], rules[k]);
    }
    size_t c = 0;
    for (; c + 1 < candidates; c += 2) {
      const size_t k = candidate[c], l = candidate[c + 1];
      double_area_pairs(rules[k], rules[l], f[k], f[l]);
    }
    if (c < candidates) f[candidate[c]] = double_area_pair(rules[candidate[c]]);
    for (size_t k = 0; k < count; ++k) {
      const size_t j = first + k;
      if (order[k] < 0) {
        ++cost.pairs_culled;
        out[j] = 0.0;
        continue;
      }
      if (order[k] > 0 && order[k] <= ElementRules::kMaxOrder && agree(f[k])) {
        // What pair_integral does with unoccluded()'s value (no visibility here).
        cost.kernel_evaluations += double_area_evaluations(rules[k]);
        if (f[k].high > 0.0) ++cost.pairs_unoccluded;
        out[j] = f[k].high > 0.0 ? f[k].high : 0.0;
        continue;
      }
      out[j] = general(j);  // from the start: its costs as pair_integral counts them
    }
  }
}

// F_ij without occluders for the part `from` of i in front of j's plane (the fraction `kept`).
// Separated pairs first try two fixed Gauss rules: the order m the Bernstein bound asks for
// (FixedOrderRule, polygon_integral.h; as raycast chooses it, with the integrand's size on the
// ellipse against its mean estimated from i's heights above j's plane) and m - 1; the pair takes
// the order-m value when the two agree within `tolerance` relative. That difference is the error
// of the lower rule (the higher one's is smaller by about r^2 >= 1 per order, r the ellipse's
// parameter), so the estimate is a posteriori, like the adaptive rule's 3x3-against-children
// difference, at m^2 + (m-1)^2 evaluations (5 to 13 on most pairs of a room at 1e-2) instead of
// the adaptive rule's 45 or more. Otherwise (touching or near pairs, no order up to
// kMaxFixedOrder, or the rules disagree) the adaptive rule decides, as before.
[[gnu::always_inline]] inline double ExactFormFactors::unoccluded(
    size_t i, size_t j, std::span<const Vec3> from, std::span<const Vec3> to, double kept,
    const Heights& i_heights, const Heights& j_heights, RowCost& cost) const {
  const PolygonRef a{from, mesh_.normal[i]}, b{to, mesh_.normal[j]};
  const double gap = glm::distance(mesh_.centroid[i], mesh_.centroid[j]) - radius_[i] - radius_[j];
  const double diameter = 2.0 * radius_[i];
  if (gap > 0.0) {
    // The integrand vanishes on j's plane about in proportion to x's height h above it; h is
    // linear, its mean the value at the kept part's centroid, and on the ellipse it grows by at
    // most sin(angle between the planes) per unit of i's diameter (pair_geometry.h's
    // grazing_scale, written out here because the double-area test below reuses its parts).
    const double height_max = i_heights.high;
    const Vec3 centre = kept < 1.0 ? geometry::centroid(from) : mesh_.centroid[i];
    const double height_mean = glm::dot(centre - mesh_.centroid[j], mesh_.normal[j]);
    const double slope = glm::length(glm::cross(mesh_.normal[i], mesh_.normal[j]));
    const double scale_i = height_mean / (height_max + slope * diameter);
    // Both elements wholly in front of each other's planes: the double-area rule first
    // (double_area.h), orders m and m - 1 on both elements, m from the bound for the larger
    // element and the smaller of the two height scales, the same acceptance test.
    if (kept == 1.0 && i_heights.low > plane_epsilon_ && j_heights.low > plane_epsilon_) {
      const int m = double_area_order(i, j, gap, i_heights, j_heights);
      if (m > 0 && m <= ElementRules::kMaxOrder) {
        DoubleAreaRules rules;
        double_area_rules(i, j, m, rules);
        const DoubleAreaPair f = double_area_pair(rules);
        cost.kernel_evaluations += double_area_evaluations(rules);
        if (agree(f)) return f.high;
      }
    }
    const int bound = order_rule_.order(gap, diameter, scale_i);
    if (bound > 0) {
      const int order = std::max(2, bound);
      const double high = polygon_form_factor_fixed(a, b, order);
      const double low = polygon_form_factor_fixed(a, b, order - 1);
      const uint64_t cells = from.size() == 4 ? 1 : from.size() - 2;
      cost.kernel_evaluations += cells * uint64_t(order * order + (order - 1) * (order - 1));
      if (std::abs(high - low) <= options_.tolerance * std::abs(high)) return kept * high;
    }
  }
  // The area rule first, while it is cheap (kAreaRuleFirst); where it is not (touching and near
  // pairs at tight tolerances), the contour integral (contour_integral.h: one-dimensional, its
  // cost grows with the logarithm of the tolerance), within `tolerance` with its rounding floor
  // in its stated error; the area rule to its full cap where that does not converge either.
  // Absolute floor 1e-16 of F_ij (per unit area, shrinking 4x per level; divided by `kept`
  // because the integral over the kept part is scaled by it): only cells whose whole contribution
  // is below double rounding stop on it.
  long long evaluations = 0;
  double estimated = 0.0;
  double f =
      polygon_integral_adaptive(a, b, nullptr, options_.tolerance, 1e-16 / kept, options_.max_depth,
                                &evaluations, kAreaRuleFirst, &estimated);
  if (evaluations >= kAreaRuleFirst) {
    cost.kernel_evaluations += uint64_t(evaluations);
    const ContourIntegral c = contour_form_factor_front(
        from, mesh_.centroid[i], mesh_.normal[i], to, mesh_.normal[j], mesh_.area[i],
        plane_epsilon_, options_.tolerance, kContourEvaluations);
    cost.kernel_evaluations += uint64_t(c.evaluations);
    if (c.converged) return c.form_factor;
    evaluations = 0;
    f = polygon_integral_adaptive(a, b, nullptr, options_.tolerance, 1e-16 / kept,
                                  options_.max_depth, &evaluations, kUnoccludedEvaluations,
                                  &estimated);
  }
  cost.kernel_evaluations += uint64_t(evaluations);
  // Stopped short of the tolerance (the work cap, or max_depth): the rest is stated.
  const double excess = kept * (estimated - options_.tolerance * std::abs(f));
  if (excess > 0.0) record_excess(i, j, excess);
  return kept * f;
}

// The mean over `from` (i's part in front of j's plane) of F_{dx -> part of j visible from x},
// the shadows of the polygons `ids` clipped away at every quadrature point (visible_polygon.h).
// The same adaptive rule, tolerance and floor as the unoccluded integral: the integrand is
// continuous in x (shadow edges move continuously), with kinks where x sees an occluder's edge
// line up with another edge, which the adaptive rule refines like a shared edge's singularity.
// Splits `from` (i's part in front of j's plane) along the plane of every occluder that touches
// i's plane (a corner within plane_epsilon_ of it, or corners on both sides) into convex pieces,
// with each piece's share of from's area. An occluder whose plane misses `from`, or runs along
// it, cuts nothing; with no such occluder `pieces` is `from` alone (share 1, the same bits).
void ExactFormFactors::split_on_contacts(size_t i, std::span<const Vec3> from,
                                         std::span<const Occluder> occluders,
                                         std::vector<std::vector<Vec3>>& pieces,
                                         std::vector<double>& shares) const {
  pieces.assign(1, std::vector<Vec3>(from.begin(), from.end()));
  shares.assign(1, 1.0);
  const Vec3& n = mesh_.normal[i];
  const Vec3& origin = from[0];
  thread_local std::vector<Vec3> back;
  for (const Occluder& o : occluders) {
    double lo = 1e300, hi = -1e300;
    for (const Vec3& c : o.corners) {
      const double h = glm::dot(c - origin, n);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
    const bool touches =
        std::min(std::abs(lo), std::abs(hi)) <= plane_epsilon_ || (lo < 0.0 && hi > 0.0);
    if (!touches) continue;
    const Vec3& point = o.corners[0];
    for (size_t p = 0, count = pieces.size(); p < count; ++p) {
      back = pieces[p];
      const double front_share = clip_to_front(pieces[p], point, o.normal, plane_epsilon_);
      if (front_share >= 1.0) continue;  // wholly in front: not cut
      const double back_share = clip_to_front(back, point, -o.normal, plane_epsilon_);
      if (front_share <= 0.0) {  // wholly behind (or a sliver in front): not cut either
        if (back_share > 0.0) pieces[p] = back;
        continue;
      }
      const double share = shares[p];
      shares[p] = share * front_share;
      if (back_share > 0.0) {
        pieces.push_back(back);
        shares.push_back(share * back_share);
      }
    }
  }
}

double ExactFormFactors::clipped_pair(size_t i, size_t j, std::span<const Vec3> from,
                                      std::span<const Vec3> to, std::span<const Occluder> occluders,
                                      double floor, long long max_evaluations, RowCost& cost,
                                      double* error) const {
  const Vec3 n = mesh_.normal[i], to_normal = mesh_.normal[j];
  const double epsilon = plane_epsilon_;
  thread_local VisibleScratch scratch;
  // j's frame and flattened corners, once for all the rule's points.
  thread_local VisibleTarget target;
  target.set(to, to_normal);
  const PointIntegrand visible = [&](const Vec3& x) {
    return visible_form_factor(x, n, target, occluders, epsilon, scratch);
  };
  long long evaluations = 0;
  const double f =
      polygon_integral_adaptive({from, n}, {to, to_normal}, &visible, options_.tolerance, floor,
                                options_.max_depth, &evaluations, max_evaluations, error);
  cost.kernel_evaluations += uint64_t(evaluations);
  return f > 0.0 ? f : 0.0;
}

void ExactFormFactors::pair_occluders(size_t i, size_t j, std::span<const Vec3> from,
                                      std::span<const Vec3> to,
                                      std::vector<Occluder>& occluders) const {
  thread_local std::vector<uint32_t> ids;
  shafts_->blockers(i, j, ids);
  // Candidates whose plane separates i from j block nothing.
  occluders.clear();
  for (uint32_t id : ids) {
    const Occluder o{scene_.polygons[id].vertices, occluder_normal_[id]};
    if (!separated_by_plane(o, from, to, plane_epsilon_)) occluders.push_back(o);
  }
}

bool ExactFormFactors::occluders_nearer(size_t i, size_t j,
                                        std::span<const Occluder> occluders) const {
  double to_i = 1e300, to_j = 1e300;
  for (const Occluder& o : occluders) {
    to_i = std::min(to_i, point_polygon_distance(mesh_.centroid[i], o.corners, o.normal));
    to_j = std::min(to_j, point_polygon_distance(mesh_.centroid[j], o.corners, o.normal));
  }
  // The margin keeps the usual side (the smaller element) where both are about as near.
  return to_i < 0.99 * to_j;
}

bool ExactFormFactors::any_visible(size_t i, size_t j, std::span<const Vec3> from,
                                   std::span<const Vec3> to, std::span<const Occluder> occluders,
                                   RowCost& cost) const {
  // Rounding slivers along contact lines (a block standing on the floor) leave pieces seen with
  // a point form factor of 2e-19 to 2e-17 (Cornell box, 4 x 4; real parts found by the probe:
  // 3e-6 and 5e-5): below the rule's own absolute floor (1e-16), they count as nothing.
  constexpr double kSeen = 1e-15;
  thread_local QuadratureRule rule;
  thread_local VisibleScratch scratch;
  thread_local VisibleTarget target;
  element_quadrature(from, 6, rule);
  target.set(to, mesh_.normal[j]);
  for (size_t k = 0; k < rule.size(); ++k) {
    ++cost.kernel_evaluations;
    if (visible_form_factor(Vec3(rule.x[k], rule.y[k], rule.z[k]), mesh_.normal[i], target,
                            occluders, plane_epsilon_, scratch) > kSeen)
      return true;
  }
  return false;
}

double ExactFormFactors::occluded(size_t i, size_t j, std::span<const Vec3> from,
                                  std::span<const Vec3> to, double kept,
                                  std::span<const Occluder> occluders, RowCost& cost,
                                  bool* proven_hidden) const {
  if (proven_hidden) *proven_hidden = false;
  // One occluder hiding j from every corner of i hides it from all of i.
  thread_local VisibleScratch scratch;
  for (const Occluder& o : occluders)
    if (hides_from_corners(o, from, mesh_.normal[i], to, mesh_.normal[j], plane_epsilon_,
                           scratch)) {
      cost.kernel_evaluations += from.size();
      if (proven_hidden) *proven_hidden = true;
      return 0.0;
    }
  // An occluder standing on i (or passing through it) makes the integrand jump along the
  // line where its plane meets i's: points on one side see past it, points on the other
  // (under a box) do not. The adaptive rule's error there falls only as 2^-depth, so i is
  // split along every such line and each convex piece integrated on its own: the jumps
  // then lie on the pieces' edges.
  thread_local std::vector<std::vector<Vec3>> pieces;
  thread_local std::vector<double> shares;
  split_on_contacts(i, from, occluders, pieces, shares);
  // Pieces share the work cap: each may use what the earlier ones left, divided among the
  // pieces still to come (so converging pieces leave budget to the harder ones).
  uint64_t budget = uint64_t(options_.max_evaluations);
  double f = 0.0, error = 0.0;
  for (size_t p = 0; p < pieces.size(); ++p) {
    // The same budget as an unoccluded pair: `tolerance` relative to the pair's own value.
    const double w = kept * shares[p];
    const long long cap =
        std::max<long long>(100, static_cast<long long>(budget / (pieces.size() - p)));
    const uint64_t before = cost.kernel_evaluations;
    double piece_error = 0.0;
    f += w * clipped_pair(i, j, pieces[p], to, occluders, 1e-16 / w, cap, cost, &piece_error);
    error += w * piece_error;
    budget -= std::min(budget, cost.kernel_evaluations - before);
  }
  // The row-sum check allows tolerance * F_ij for this entry; state what is beyond it.
  const double excess = error - options_.tolerance * f;
  if (excess > 0.0) record_excess(i, j, excess);
  return f > 0.0 ? f : 0.0;
}

void ExactFormFactors::record_excess(size_t i, size_t j, double excess) const {
  const uint64_t key = uint64_t(i) * uint64_t(mesh_.size()) + uint64_t(j);
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  if (!capped_pairs_.insert(key).second) return;  // recomputed (row by row: once from each row)
  row_excess_[i] += to_fixed(excess);
  row_excess_[j] += to_fixed(reciprocal(excess, mesh_.area[i], mesh_.area[j]));
}

double ExactFormFactors::row_excess(size_t i) const {
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  return i < row_excess_.size() ? from_fixed(row_excess_[i]) : 0.0;
}

double ExactFormFactors::largest_row_excess() const {
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  double largest = 0.0;
  for (FixedSum e : row_excess_) largest = std::max(largest, from_fixed(e));
  return largest;
}

size_t ExactFormFactors::pairs_capped() const {
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  return capped_pairs_.size() + loaded_pairs_;
}

std::vector<double> ExactFormFactors::row_excesses() const {
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  std::vector<double> rows(row_excess_.size());
  for (size_t i = 0; i < rows.size(); ++i) rows[i] = from_fixed(row_excess_[i]);
  return rows;
}

void ExactFormFactors::set_row_excesses(std::vector<double> excess, size_t pairs) const {
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  // Exact round trip of what row_excesses() gave (fixed_sum.h).
  row_excess_.assign(excess.size(), 0);
  for (size_t i = 0; i < excess.size(); ++i) row_excess_[i] = to_fixed(excess[i]);
  capped_pairs_.clear();
  loaded_pairs_ = pairs;
}

void save_row_excess(const ExactFormFactors& method, const std::string& matrix_file) {
  const std::vector<double> rows = method.row_excesses();
  std::vector<double> data(rows.size() + 1, double(method.pairs_capped()));
  std::copy(rows.begin(), rows.end(), data.begin() + 1);
  // Bound to the matrix file's header and key, under a checksum (matrix_cache.h), as raycast's
  // ".sigma" is: a flipped bit in a row's excess would otherwise understate its error unseen.
  // Best effort: without it the cached matrix is not used (load_row_excess).
  write_matrix_side_file(matrix_file, ".excess", data.data(), data.size() * sizeof(double));
}

bool load_row_excess(const ExactFormFactors& method, const std::string& matrix_file, size_t n) {
  const std::string side = matrix_file + ".excess";
  const auto bytes = read_matrix_side_file(matrix_file, ".excess", (n + 1) * sizeof(double));
  std::vector<double> data(n + 1);
  if (bytes) std::memcpy(data.data(), bytes->data(), bytes->size());
  bool ours = bool(bytes);
  for (double v : data) ours = ours && v >= 0.0 && std::isfinite(v);
  if (!ours) {
    // Missing is the quiet case (a matrix cached by another method's build path); a file that is
    // there but fails its checks is named, since its matrix is rebuilt for it.
    std::error_code ec;
    if (std::filesystem::exists(side, ec))
      log::warning(side +
                   ": refused (checksum, size, matrix header or value check failed); the "
                   "matrix is rebuilt");
    return false;
  }
  const size_t pairs = size_t(data[0]);
  data.erase(data.begin());
  method.set_row_excesses(std::move(data), pairs);
  return true;
}

// Visibility allowance of visibility=rays (still the empirical one raycast had before its rows
// carried their own sampling error): 0.04/sqrt(rays), five times the largest excess measured on
// builtin:cornell at --subdiv 6 (0.0019), falling as the noise.
static double visibility_allowance(double rays) {
  return 0.04 / std::sqrt(std::max(rays, 1.0));
}

double ExactFormFactors::stated_row_sum_error(std::string* basis) const {
  const double tolerance = options_.tolerance;
  const bool rays = options_.visibility_rays;
  // clip mode: pairs stopped by the work cap add their remaining error (exact.h)
  const double capped = largest_row_excess();
  const double error = tolerance + kFloatStorageRowError + capped +
                       (rays ? visibility_allowance(double(options_.rays)) : 0.0);
  if (basis) {
    char buffer[600];
    std::snprintf(buffer, sizeof buffer, "exact: quadrature tolerance %.3g + float storage 1e-7%s",
                  tolerance, rays ? " + visibility 0.04/sqrt(rays)" : "");
    if (capped > 0.0) {
      const size_t used = std::strlen(buffer);
      std::snprintf(buffer + used, sizeof buffer - used,
                    " + %.3g (the largest row's remaining error of %zu pairs stopped short of "
                    "the tolerance by max_evaluations or max_depth)",
                    capped, pairs_capped());
    }
    *basis = buffer;
  }
  return error;
}

std::optional<double> ExactFormFactors::stated_reciprocity_error() const {
  // F_ba = F_ab (A_a / A_b): A_b F_ba and A_a F_ab differ by the rounding of one division and
  // two products, at most 3 * 2^-53 relative; 4 * 2^-52 leaves room for the sum it is held to.
  return 4.0 * std::numeric_limits<double>::epsilon();
}

void ExactFormFactors::orient_row(size_t i, std::span<double> row) const {
  for (size_t j = 0; j < row.size(); ++j)
    if (!integrates_from(mesh_, i, j)) row[j] = reciprocal(row[j], mesh_.area[j], mesh_.area[i]);
}

void ExactFormFactors::pair_entries(size_t i, std::span<double> upper, std::span<double> lower,
                                    RowCost& cost) const {
  // As build_matrix_symmetric: the pairs' work once, their classes for both entries.
  RowCost one;
  upper_row(i, upper, one);
  cost.rays += one.rays;
  cost.kernel_evaluations += one.kernel_evaluations;
  cost.pairs_culled += 2 * one.pairs_culled;
  cost.pairs_unoccluded += 2 * one.pairs_unoccluded;
  cost.pairs_traced += 2 * one.pairs_traced;
  for (size_t j = i + 1; j < upper.size(); ++j) {
    const double f = upper[j];  // F_ab over the integrated side a
    if (integrates_from(mesh_, i, j)) {
      lower[j] = reciprocal(f, mesh_.area[i], mesh_.area[j]);  // orient_row(j) at column i
    } else {
      upper[j] = reciprocal(f, mesh_.area[j], mesh_.area[i]);  // orient_row(i) at column j
      lower[j] = f;
    }
  }
}

std::vector<char> ExactFormFactors::pair_block_state() const {
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  const size_t words = row_excess_.size() + 1;
  std::vector<FixedSum> values(words);
  for (size_t k = 0; k < words; ++k)
    values[k] = k == 0 ? FixedSum(capped_pairs_.size() + loaded_pairs_) : row_excess_[k - 1];
  std::vector<char> bytes(words * sizeof(FixedSum));
  std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

bool ExactFormFactors::restore_pair_block_states(
    const std::vector<std::vector<char>>& states) const {
  const size_t n = mesh_.size();
  std::vector<FixedSum> sum(n + 1, 0), data(n + 1);
  for (const std::vector<char>& state : states) {
    if (state.size() != (n + 1) * sizeof(FixedSum)) return false;
    std::memcpy(data.data(), state.data(), state.size());
    for (size_t k = 0; k <= n; ++k) sum[k] += data[k];
  }
  const std::lock_guard<std::mutex> lock(excess_mutex_);
  row_excess_.assign(sum.begin() + 1, sum.end());
  capped_pairs_.clear();
  loaded_pairs_ = size_t(sum[0]);
  return true;
}

void ExactFormFactors::row(size_t i, std::span<double> out, RowCost& cost) const {
  for (size_t j = 0; j < out.size(); ++j) out[j] = pair(i, j, cost);
}

bool ExactFormFactors::row_part(size_t i, size_t lo, size_t hi, std::span<double> out,
                                RowCost& cost) const {
  for (size_t j = lo; j < hi; ++j) out[j] = pair(i, j, cost);
  return true;
}

}  // namespace radlab
