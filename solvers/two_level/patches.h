// Patches and elements: Cohen et al. 1988's two-level discretisation (§3.4 "substructuring", and
// Cohen, Greenberg, Immel & Brock 1986). Coarse patches shoot light; the fine elements they are
// split into receive it. A patch is a set of elements; its radiosity is the area-weighted mean of
// theirs.
//
// The two-level system in the element unknowns (docs/solvers.md, "Two levels") is defined by the
// patches' P x n patch-to-element rows P_pe (solvers/two_level/patch_rows.h: one hemicube at each
// patch's centre as the paper, or the mean of its elements' rows):
//
//   B_e = E_e + rho_e sum_j K_ej B_j,    K_ej = F_{e,p(j)} A_j / A_p(j),   F_{e,p} = P_pe A_p /
//   A_e,
//
// where p(j) is the patch holding element j and A_p = sum of its elements' areas: element e
// gathers from each patch the patch's mean radiosity, with the element-to-patch factor that
// reciprocity gives from the patch's row. A patch p shooting delivers rho_e P_pe (A_p / A_e) dB_p
// to every element e: the exact transpose of the gather, so patch shooting and element gathering
// solve one system, and the certified reference (solvers/two_level/two_level_reference.h) solves
// it from P with no n x n matrix. With one element per patch and centre rows, P is the one-level
// hemicube matrix row for row and the system is the one one-level shooting solves (docs).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "formfactor/matrix/matrix.h"
#include "scene/mesh.h"

namespace radlab {

// A partition of the elements into patches. Members of a patch are listed in increasing element
// order.
class Patches {
 public:
  size_t size() const { return first_.empty() ? 0 : first_.size() - 1; }
  size_t elements() const { return patch_of_.size(); }
  std::span<const uint32_t> members(size_t p) const {
    return {members_.data() + first_[p], first_[p + 1] - first_[p]};
  }
  // A_e / A_p for the members of p, in members() order (exactly 1 for a one-element patch).
  std::span<const double> weights(size_t p) const {
    return {weight_.data() + first_[p], first_[p + 1] - first_[p]};
  }
  double area(size_t p) const { return area_[p]; }
  uint32_t patch_of(size_t e) const { return patch_of_[e]; }
  std::span<const uint32_t> patch_of() const { return patch_of_; }
  // The largest number of elements in one patch.
  size_t largest() const { return largest_; }

  // From a patch index per element (every patch index in [0, patches) used at least once).
  static Patches from_assignment(std::span<const uint32_t> patch_of, std::span<const double> area,
                                 size_t patches);

 private:
  std::vector<uint32_t> first_, members_, patch_of_;
  std::vector<double> weight_, area_;
  size_t largest_ = 0;
};

// One patch per element: the one-level system.
Patches element_patches(const Mesh& mesh);
// One patch per input polygon (Cohen's patches are the modelled surfaces).
Patches polygon_patches(const Mesh& mesh);
// Patches from a coarser mesh of the same scene: polygons meshed with edges at most patch_size
// (build_mesh's element_size), each element joined to the patch cell of its own polygon that
// holds its centroid. UsageError for patch_size <= 0, not finite, or larger than the scene's
// bounding-box diagonal (every polygon would be one patch: use polygon patches).
Patches coarse_mesh_patches(const Scene& scene, const Mesh& mesh, double patch_size);

// How patches are formed (experiment files: [patches]; docs/experiments.md).
struct PatchOptions {
  std::string from = "elements";  // elements (one-level) | polygons | size
  double size = 0.0;              // patch edge length for from = "size" (m)
  // Patch rows (solvers/two_level/patch_rows.h): centre (one hemicube at the patch's centre, the
  // paper) | mean (area-weighted mean of the element rows) | auto (centre with hemicubes, else
  // mean).
  std::string rows = "auto";

  bool two_level() const { return from != "elements"; }
  void validate() const;  // UsageError naming the bad value
  // "from=polygons" / "from=size,size=0.5" [",rows=mean"] (run ids, cache keys)
  std::string canonical() const;
  // The rule `rows` names for form-factor method `method` (auto resolved).
  std::string resolved_rows(const std::string& method) const;
};
Patches make_patches(const Scene& scene, const Mesh& mesh, const PatchOptions& options);

// A dense rows x n matrix in float or double (the patch rows).
class RowMatrix {
 public:
  RowMatrix() = default;
  RowMatrix(size_t rows, size_t n, Precision precision);
  size_t rows() const { return rows_; }
  size_t columns() const { return n_; }
  Precision precision() const { return precision_; }
  template <class Fn>
  decltype(auto) visit_row(size_t p, Fn&& fn) const {
    if (precision_ == Precision::kFloat) return fn(f32_.data() + p * n_);
    return fn(f64_.data() + p * n_);
  }
  double at(size_t p, size_t e) const {
    return precision_ == Precision::kFloat ? double(f32_[p * n_ + e]) : f64_[p * n_ + e];
  }
  void set(size_t p, size_t e, double v) {
    if (precision_ == Precision::kFloat)
      f32_[p * n_ + e] = float(v);
    else
      f64_[p * n_ + e] = v;
  }

 private:
  size_t rows_ = 0, n_ = 0;
  Precision precision_ = Precision::kFloat;
  std::vector<float> f32_;
  std::vector<double> f64_;
};

// P_pe = sum_{i in p} (A_i / A_p) F_ie from a dense element matrix, stored in `precision` (sums in
// double): the `mean` rule's rows when F is at hand (tests).
RowMatrix patch_rows(const FormFactorMatrix& F, const Patches& patches, Precision precision);

}  // namespace radlab
