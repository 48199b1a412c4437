#include "formfactor/exact.h"

#include <cstdio>

#include "core/error.h"
#include "formfactor/occlusion.h"
#include "formfactor/polygon_integral.h"
#include "formfactor/raycast.h"
#include "formfactor/shaft.h"

namespace radlab {

ExactOptions ExactOptions::from(ParamBag& bag) {
  ExactOptions o;
  o.tolerance = bag.get_double("tolerance", o.tolerance);
  o.max_depth = int(bag.get_int("max_depth", o.max_depth, kIntMin, kIntMax));
  o.visibility_rays = bag.get_choice("visibility", "refuse", {"refuse", "rays"}) == "rays";
  if (o.visibility_rays) {
    o.rays = int(bag.get_int("rays", o.rays, kIntMin, kIntMax));
    o.seed = uint64_t(bag.get_int("seed", 0, 0, kInt64Max));
  } else if (bag.has("rays") || bag.has("seed")) {
    throw UsageError("exact: 'rays' and 'seed' apply only with visibility=rays");
  }
  o.validate();
  return o;
}

void ExactOptions::validate() const {
  if (!(tolerance >= 1e-15 && tolerance < 1.0))
    throw UsageError("exact: tolerance must lie in [1e-15,1), got " + std::to_string(tolerance));
  if (max_depth < 1 || max_depth > 24)
    throw UsageError("exact: max_depth must lie in [1,24], got " + std::to_string(max_depth));
  if (rays < 1 || rays > 4096)
    throw UsageError("exact: rays must lie in [1,4096], got " + std::to_string(rays));
}

std::string ExactOptions::canonical() const {
  char buffer[200];
  if (visibility_rays)
    std::snprintf(buffer, sizeof buffer,
                  "max_depth=%d,rays=%d,seed=%llu,tolerance=%.6g,visibility=rays", max_depth, rays,
                  static_cast<unsigned long long>(seed), tolerance);
  else
    std::snprintf(buffer, sizeof buffer, "max_depth=%d,tolerance=%.6g,visibility=refuse", max_depth,
                  tolerance);
  return buffer;
}

ExactFormFactors::ExactFormFactors(const Scene& scene, const Mesh& mesh, ExactOptions options)
    : scene_(scene), mesh_(mesh), options_((options.validate(), options)) {
  plane_epsilon_ = plane_epsilon(mesh);
  if (is_convex_enclosure(scene)) {
    nothing_occludes_ = true;
    return;
  }
  if (options_.visibility_rays) {
    visibility_ = std::make_unique<Visibility>(scene, mesh, options_.rays, options_.seed, true);
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
  } else {
    notes.push_back(is_convex_enclosure(scene_)
                        ? "visibility: none (the scene is a convex enclosure, nothing can occlude)"
                        : "visibility: none (shaft culling proved every pair unoccluded)");
  }
  return notes;
}

double ExactFormFactors::pair(size_t i, size_t j, RowCost& cost) const {
  if (i == j) return 0.0;
  if (!pair_faces(mesh_, i, j, plane_epsilon_)) {
    ++cost.pairs_culled;
    return 0.0;
  }
  thread_local std::vector<Vec3> from, to;
  mesh_.corners(i, from);
  mesh_.corners(j, to);
  // Integrate only over the part of i in front of j's plane (no jump in the integrand).
  const double kept = clip_to_front(from, mesh_.centroid[j], mesh_.normal[j], plane_epsilon_);
  if (kept <= 0.0) return 0.0;
  long long evaluations = 0;
  // Absolute floor 1e-16 of F_ij (per unit area, shrinking 4x per level; divided by `kept`
  // because the integral over the kept part is scaled by it): only cells whose whole contribution
  // is below double rounding stop on it.
  const double f = kept * polygon_form_factor_adaptive(
                              {from, mesh_.normal[i]}, {to, mesh_.normal[j]}, options_.tolerance,
                              1e-16 / kept, options_.max_depth, &evaluations);
  cost.kernel_evaluations += uint64_t(evaluations);
  if (f <= 0.0) return 0.0;
  if (visibility_) return f * visibility_->fraction(i, j, cost);
  ++cost.pairs_unoccluded;
  return f;
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
