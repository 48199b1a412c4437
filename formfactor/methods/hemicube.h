// `hemicube` form factors (Cohen & Greenberg 1985; used by Cohen et al. 1988 at R = 150).
//
// Row i: a hemicube at the centroid of element i, aligned with i's first edge (local frame u, v,
// n with n the element's normal), one top face of R x R pixels at height 1 and four side faces of
// R x R/2 pixels. Every other element is rasterised onto the faces by a software z-buffer (an
// item buffer): a pixel holds the nearest element covering its centre. Then
//
//   F_ij = sum of the weights of the pixels that hold j.
//
// Rasterisation: the mesh vertices are moved into i's frame once per row (eye at the origin) and
// snapped to a grid of ~1e-9 of the scene's size, so that corners different polygons compute
// separately (equal up to rounding) become bit-identical.
// An element whose corners all project onto one face is scan-converted there directly; one that
// straddles faces or the horizon is drawn on every face whose frustum it reaches, clipped only by
// that face's near plane (the scan conversion keeps to the face's own pixels, and one clipping
// plane per face cuts an edge two elements share at one and the same point). The depth test uses
// 1/depth, which is affine in face coordinates for a planar polygon and is computed exactly from
// the element's plane (no interpolation of per-vertex depths). Pixel coverage is "the pixel centre
// lies in the projected polygon", half-open (rows ymin <= y < ymax, columns xl <= x < xr) with
// every edge crossing computed from the edge's ends in a canonical order: a centre on an edge that
// two elements share goes to exactly one of them — no holes, no double counts, no bias in symmetric
// scenes. (Edges that meet only geometrically, at T-junctions, can still round differently; a
// centre within rounding of such an edge may then see what lies behind it.) Back-facing elements
// occlude like any other but add nothing to the row; elements wholly at or below i's horizon are
// skipped (counted in pairs_culled).
//
// This is the hemicube's real behaviour, aliasing included: a small distant element is hit or
// missed by whole pixels, which is what reproducing the papers needs.
//
// Weights (`weights`):
//   midpoint  the classic delta form factors: top face dA / (pi (s^2 + t^2 + 1)^2), side faces
//             t dA / (pi (s^2 + t^2 + 1)^2), at the pixel centre (s, t); dA = (2/R)^2. Their sum
//             is 1 + O(1/R^2), not 1.
//   exact     each pixel's exact form factor from the eye point (normal n) to the pixel square,
//             by Lambert's formula (point_polygon.h). The pixels tile the hemicube, so the weights
//             sum to 1 up to rounding, and a closed scene's rows sum to 1.
// Both are computed once per method (3 R^2 numbers).
//
// Cost per row: O(n) vertex transforms and element set-ups plus O(pixels covered) depth tests,
// plus O(3 R^2) to clear the buffers and sum the weights. No rays (RowCost::kernel_evaluations
// counts depth tests).
//
// Parameters (their defaults are HemicubeOptions' own; `radlab solvers` prints them): resolution
// (R, even), weights (midpoint | exact).
#pragma once

#include <cstdint>
#include <vector>

#include "formfactor/form_factor_method.h"

namespace radlab {

enum class HemicubeWeighting { kMidpoint, kExact };

struct HemicubeOptions {
  int resolution = 150;  // R: pixels across the top face; more pixels, less aliasing, O(R^2) cost
  HemicubeWeighting weights = HemicubeWeighting::kMidpoint;  // classic, or exact per pixel

  static HemicubeOptions from(ParamBag& bag);
  void validate() const;
  std::string canonical() const;
};

// The five faces in buffer order: top (R x R), then the sides facing +u, -u, +v, -v (R wide,
// R/2 high, row 0 at the horizon). Pixel (a, b) of a face sits at offset face_offset + b*R + a.
struct HemicubeLayout {
  int resolution = 0;
  size_t face_offset(int face) const {
    const size_t r = size_t(resolution);
    return face == 0 ? 0 : r * r + size_t(face - 1) * r * (r / 2);
  }
  int face_height(int face) const { return face == 0 ? resolution : resolution / 2; }
  size_t pixels() const { return 3 * size_t(resolution) * size_t(resolution); }
};

// The 3 R^2 pixel weights in HemicubeLayout order.
std::vector<double> hemicube_weights(int resolution, HemicubeWeighting weighting);

class HemicubeFormFactors final : public FormFactorMethod {
 public:
  static constexpr int32_t kNothing = -1;  // no element, or a back face, covers the pixel

  HemicubeFormFactors(const Scene& scene, const Mesh& mesh, HemicubeOptions options);
  std::string name() const override { return "hemicube"; }
  std::string parameters() const override { return options_.canonical(); }
  std::vector<std::string> left_out() const override;
  void row(size_t i, std::span<double> out, RowCost& cost) const override;

  // Stated error (form_factor_method.h): a raw row is at most the sum of its pixel weights (each
  // pixel holds one element), so 1 + the weights' excess over 1 + rounding. No reciprocity is
  // stated: a row is one point's view, aliased by whole pixels.
  double stated_row_sum_error(std::string* basis = nullptr) const override;
  // Emitters' sampling (form_factor_method.h): known for every row computed so far, kept
  // beside a cached matrix in the ".emitters" side file (a matrix loaded without it is rebuilt).
  std::optional<EmitterSampling> row_emitter_sampling(size_t i) const override;
  void save_side_files(const std::string& matrix_file) const override;
  bool load_side_files(const std::string& matrix_file, size_t n) const override;
  // Blocked builds: ".emitters" holds two arrays of one float per row.
  std::vector<RowSideFile> row_side_files() const override { return {{".emitters", 2}}; }
  // row_at() with element's normal and frame (two levels' patch rows "centre").
  bool row_at_point(const Vec3& eye, size_t element, std::span<double> out,
                    RowCost& cost) const override {
    row_at(eye, mesh_.normal[element], frame_u_[element], out, cost);
    return true;
  }

  // One hemicube at an arbitrary eye point on a surface (unit `normal`, unit tangent `u` in its
  // plane as the first frame axis): out[j] = the form factor from that point to element j. The
  // same rasterisation as row(); elements in the eye's plane are culled, so a patch's own
  // elements add nothing when the eye lies on the patch (solvers/two_level/patch_rows.h). row(i)
  // is row_at(centroid, normal and frame_u of i) with i itself skipped. Thread-safe.
  void row_at(const Vec3& eye, const Vec3& normal, const Vec3& u, std::span<double> out,
              RowCost& cost) const;
  // The first frame axis of element i's hemicube (its first edge, in its plane).
  const Vec3& frame_u(size_t i) const { return frame_u_[i]; }

  // The item buffer of element i's hemicube (HemicubeLayout order): the element seen through
  // each pixel, or kNothing. For tests and pictures.
  void item_buffer(size_t i, std::vector<int32_t>& items) const;
  const std::vector<double>& weights() const { return weights_; }
  HemicubeLayout layout() const { return {options_.resolution}; }

 private:
  struct Buffers;
  // Fills the item buffer of element i; returns the number of depth tests.
  uint64_t rasterise(size_t i, Buffers& buffers, RowCost& cost) const;
  // The same at eye c, frame (u, n x u, n), element `skip` (or -1: none) left out.
  uint64_t rasterise_at(const Vec3& c, const Vec3& n, const Vec3& u, int64_t skip, Buffers& buffers,
                        RowCost& cost) const;
  // The three stages of rasterise_at that do not depend on the element drawn:
  // every mesh vertex in the hemicube's frame (local coordinates, face, pixel coordinates);
  void project_vertices(const Vec3& c, const Vec3& n, const Vec3& u, const Vec3& v,
                        Buffers& buffers) const;
  // a polygon that straddles faces, clipped to face f's near plane and projected to its pixels
  // (X, Y); returns the corner count, 0 when the polygon cannot reach the face;
  static int project_onto_face(const Vec3* poly, int m, int f, double near, double half,
                               Vec3* clipped, double* X, double* Y);
  // the pixels claimed by candidates of two or more elements (cracks), settled once all are drawn.
  static void resolve_cracks(Buffers& buffers);
  // out[j] = sum of the weights of the pixels holding j.
  void accumulate(const Buffers& buffers, std::span<double> out) const;
  // Row i's emitter sampling from the footprints rasterise() drew (buffers.drawn).
  void record_emitter_sampling(size_t i, const Buffers& buffers) const;

  const Mesh& mesh_;
  HemicubeOptions options_;
  std::vector<double> weights_;
  std::vector<Vec3> frame_u_;  // per element: the hemicube's first tangent axis
  double epsilon_ = 0.0;       // distances below this count as zero (metres)
  double near_ = 0.0;          // near plane of every face (metres from the eye)
  double grid_ = 1.0;          // vertices in the hemicube's frame are snapped to this (metres)
  // Emitting elements, grouped by polygon (emitters_), their mean emission over channels, and
  // each element's slot in emitters_ (-1: not emitting).
  std::vector<uint32_t> emitters_;
  std::vector<double> emitter_luminance_;
  std::vector<int32_t> emitter_slot_;
  // Per row: row_emitter_sampling's error (rounded up) and exact value; NaN until computed.
  mutable std::vector<float> row_emitter_error_, row_emitter_exact_;
};

}  // namespace radlab
