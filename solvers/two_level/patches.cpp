// Patches, patch rows and the two-level matrix (see patches.h).
#include "solvers/two_level/patches.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numeric>

#include "core/error.h"
#include "core/text.h"
#include "formfactor/registry.h"

namespace radlab {

Patches Patches::from_assignment(std::span<const uint32_t> patch_of, std::span<const double> area,
                                 size_t patches) {
  Patches P;
  const size_t n = patch_of.size();
  P.patch_of_.assign(patch_of.begin(), patch_of.end());
  P.first_.assign(patches + 1, 0);
  for (uint32_t p : patch_of) ++P.first_[size_t(p) + 1];
  for (size_t p = 0; p < patches; ++p) {
    if (P.first_[p + 1] == 0)
      throw InputError("patches: patch " + std::to_string(p) + " holds no element");
    P.largest_ = std::max<size_t>(P.largest_, P.first_[p + 1]);
    P.first_[p + 1] += P.first_[p];
  }
  P.members_.resize(n);
  std::vector<uint32_t> fill(P.first_.begin(), P.first_.end() - 1);
  for (size_t e = 0; e < n; ++e) P.members_[fill[patch_of[e]]++] = uint32_t(e);
  P.area_.assign(patches, 0.0);
  for (size_t p = 0; p < patches; ++p)
    for (uint32_t e : P.members(p)) P.area_[p] += area[e];
  P.weight_.resize(n);
  for (size_t p = 0; p < patches; ++p)
    for (uint32_t k = P.first_[p]; k < P.first_[p + 1]; ++k)
      // Exactly 1 for a one-element patch (A_p is then A_e itself): the one-level system's bits.
      P.weight_[k] = area[P.members_[k]] / P.area_[p];
  return P;
}

Patches element_patches(const Mesh& mesh) {
  std::vector<uint32_t> own(mesh.size());
  std::iota(own.begin(), own.end(), 0u);
  return Patches::from_assignment(own, mesh.area, mesh.size());
}

Patches polygon_patches(const Mesh& mesh) {
  // Polygons left without elements (none, after validation) would be empty patches: renumber.
  std::vector<uint32_t> index(mesh.first_element_of_polygon.size(), 0);
  uint32_t count = 0;
  for (size_t q = 0; q + 1 < mesh.first_element_of_polygon.size(); ++q)
    if (mesh.first_element_of_polygon[q + 1] > mesh.first_element_of_polygon[q]) index[q] = count++;
  std::vector<uint32_t> patch_of(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) patch_of[e] = index[mesh.polygon[e]];
  return Patches::from_assignment(patch_of, mesh.area, count);
}

namespace {

// How far p lies inside the convex polygon (corners c, unit normal n), in metres: the smallest
// signed distance to its edges' lines, positive inside.
double inside_depth(const std::vector<Vec3>& c, const Vec3& n, const Vec3& p) {
  double depth = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < c.size(); ++k) {
    const Vec3 edge = c[(k + 1) % c.size()] - c[k];
    const Vec3 inward = glm::cross(n, edge);
    const double length = glm::length(inward);
    if (!(length > 0)) continue;
    depth = std::min(depth, glm::dot(p - c[k], inward) / length);
  }
  return depth;
}

}  // namespace

Patches coarse_mesh_patches(const Scene& scene, const Mesh& mesh, double patch_size) {
  PatchOptions options;
  options.from = "size";
  options.size = patch_size;
  options.validate();
  Vec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const Polygon& poly : scene.polygons)
    for (const Vec3& v : poly.vertices) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
  const double diagonal = glm::length(hi - lo);
  if (!(patch_size <= diagonal))
    throw UsageError("patches: size " + text::format_double(patch_size) +
                     " m exceeds the scene's extent (bounding-box diagonal " +
                     text::format_double(diagonal) +
                     " m): every polygon would be one patch; use from = \"polygons\"");
  MeshOptions coarse;
  coarse.element_size = patch_size;
  const Mesh cells = build_mesh(scene, coarse);
  std::vector<uint32_t> patch_of(mesh.size());
  std::vector<uint8_t> used(cells.size(), 0);
  std::vector<Vec3> corners;
  for (size_t e = 0; e < mesh.size(); ++e) {
    const uint32_t q = mesh.polygon[e];
    double best = -std::numeric_limits<double>::infinity();
    uint32_t chosen = cells.first_element_of_polygon[q];
    for (uint32_t c = cells.first_element_of_polygon[q]; c < cells.first_element_of_polygon[q + 1];
         ++c) {
      cells.corners(c, corners);
      const double depth = inside_depth(corners, cells.normal[c], mesh.centroid[e]);
      if (depth > best) {
        best = depth;
        chosen = c;
      }
    }
    patch_of[e] = chosen;
    used[chosen] = 1;
  }
  // Cells no element centre falls in (elements coarser than the cells) are dropped.
  std::vector<uint32_t> index(cells.size(), 0);
  uint32_t count = 0;
  for (size_t c = 0; c < cells.size(); ++c)
    if (used[c]) index[c] = count++;
  for (uint32_t& p : patch_of) p = index[p];
  return Patches::from_assignment(patch_of, mesh.area, count);
}

void PatchOptions::validate() const {
  if (from != "elements" && from != "polygons" && from != "size")
    throw UsageError("patches: from must be elements, polygons or size, got '" + from + "'");
  if (from == "size" && !(size > 0.0 && std::isfinite(size)))
    throw UsageError("patches: size must be a finite length > 0 (m) with from = \"size\", got " +
                     text::format_double(size));
  if (from != "size" && size != 0.0)
    throw UsageError("patches: size is used only with from = \"size\"");
  if (rows != "auto" && rows != "centre" && rows != "mean")
    throw UsageError("patches: rows must be auto, centre or mean, got '" + rows + "'");
  if (from == "elements" && rows != "auto")
    throw UsageError("patches: rows is used only with two levels (from = polygons or size)");
}

std::string PatchOptions::resolved_rows(const std::string& method) const {
  if (rows != "auto") return rows;
  return form_factor_method_info(method).rows_at_points ? "centre" : "mean";
}

std::string PatchOptions::canonical() const {
  std::string text = "from=" + from;
  if (from == "size") text += ",size=" + text::format_double(size);
  if (rows != "auto") text += ",rows=" + rows;
  return text;
}

Patches make_patches(const Scene& scene, const Mesh& mesh, const PatchOptions& options) {
  options.validate();
  if (options.from == "polygons") return polygon_patches(mesh);
  if (options.from == "size") return coarse_mesh_patches(scene, mesh, options.size);
  return element_patches(mesh);
}

RowMatrix::RowMatrix(size_t rows, size_t n, Precision precision)
    : rows_(rows), n_(n), precision_(precision) {
  if (precision == Precision::kFloat)
    f32_.assign(rows * n, 0.0f);
  else
    f64_.assign(rows * n, 0.0);
}

RowMatrix patch_rows(const FormFactorMatrix& F, const Patches& patches, Precision precision) {
  const size_t n = F.size();
  RowMatrix P(patches.size(), n, precision);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, patches.size()),
                    [&](const tbb::blocked_range<size_t>& range) {
                      std::vector<double> row(n);
                      for (size_t p = range.begin(); p != range.end(); ++p) {
                        std::fill(row.begin(), row.end(), 0.0);
                        const auto members = patches.members(p);
                        const auto weights = patches.weights(p);
                        for (size_t k = 0; k < members.size(); ++k)
                          F.visit_row(members[k], [&](const auto* Fi) {
                            for (size_t e = 0; e < n; ++e) row[e] += weights[k] * double(Fi[e]);
                          });
                        for (size_t e = 0; e < n; ++e) P.set(p, e, row[e]);
                      }
                    });
  return P;
}

}  // namespace radlab
