// `raycast` form factors (DESIGN §3), the default method.
//
//   F_ij = F^u_ij * V_ij
//
// F^u_ij, the unoccluded form factor, integrates Lambert's exact point-to-polygon formula over
// the part of element i in front of j's plane (clip_to_front; the formula itself clips j to i's
// tangent plane): a Gauss rule whose order follows from the pair's separation and from how
// nearly the kept part grazes j's plane (Bernstein bound, polygon_integral.h), or for near and
// touching pairs the contour integral (contour_integral.h: Stokes' theorem turns the pair's
// double area integral into one over both outlines, elementary inside and one-dimensional
// outside), with the adaptive area rule where that does not converge and first on pairs it
// finishes cheaply. V_ij, the visibility fraction, is the share of `rays` Embree
// occlusion rays that arrive unblocked between stratified, jittered points on those same two
// parts (i in front of j's plane, j in front of i's): rays from a part the integral leaves out
// would be blocked by the very polygon that cuts it off. The points depend only on
// (seed, min(i,j), max(i,j)), so V_ij = V_ji and reciprocity is kept up to the quadrature of F^u.
//
// Left out, and counted: pairs facing away or coplanar (no work, pairs_culled); visibility rays
// everywhere when the scene is a convex enclosure, and for every pair whose shaft holds no
// polygon that could block it (shaft.h; pairs_unoccluded).
//
// V's error is not controlled by `tolerance`: it is sampling noise, estimated per pair
// (visibility.h) and carried into each row's stated error as 5 sigma of the row's sum
// (row_sampling_error; diagnostics.h). Close pairs draw their rays in solid angle (visibility.h).
//
// Parameters (their defaults are RaycastOptions' own; `radlab solvers` prints them): tolerance
// (relative quadrature error per pair), rays (per occludable pair), max_rays, seed, max_order
// (largest fixed Gauss rule before going adaptive), shafts (shaft culling on or off; off only to
// measure what it saves).
#pragma once

#include <atomic>
#include <memory>

#include "formfactor/form_factor_method.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/visibility/visibility.h"

namespace radlab {

struct RaycastOptions {
  double tolerance = 1e-4;  // relative quadrature error per pair; smaller costs more points
  int rays = 16;            // visibility rays per occludable pair; the noise in V falls as 1/sqrt
  int max_rays = 4096;      // up to this many for partly occluded pairs with large F (rays_for)
  uint64_t seed = 0;        // jitter of the visibility sample points
  int max_order = 8;        // largest fixed Gauss rule per axis before adaptive subdivision
  bool shafts = true;       // shaft culling: no rays for pairs nothing can block (same result,
                            // fewer rays; false only to measure the saving)

  static RaycastOptions from(ParamBag& bag);
  void validate() const;
  std::string canonical() const;
};

class RaycastFormFactors;
void save_row_sampling_errors(const RaycastFormFactors& method, const std::string& matrix_file);
bool load_row_sampling_errors(const RaycastFormFactors& method, const std::string& matrix_file,
                              size_t n);

class RaycastFormFactors final : public FormFactorMethod {
 public:
  RaycastFormFactors(const Scene& scene, const Mesh& mesh, RaycastOptions options);
  std::string name() const override { return "raycast"; }
  std::string parameters() const override { return options_.canonical(); }
  std::vector<std::string> left_out() const override;
  void row(size_t i, std::span<double> out, RowCost& cost) const override;
  bool row_part(size_t i, size_t lo, size_t hi, std::span<double> out,
                RowCost& cost) const override;
  // A build of every row traces each pair once: V_ji reuses V_ij (Visibility::remember_pairs).
  void begin_all_rows() const override { visibility_.remember_pairs(true); }
  void end_all_rows() const override { visibility_.remember_pairs(false); }

  // Stated errors (form_factor_method.h): a row sum within the quadrature tolerance, float
  // storage and kRowSamplingSigmas standard errors of the row's visibility sampling, plus what
  // its integrals left beyond the tolerance; reciprocity within the tolerance (V_ij = V_ji, the
  // same rays), stated only while no pair stopped short of it.
  double stated_row_sum_error(std::string* basis = nullptr) const override;
  bool states_row_allowances() const override { return true; }
  double row_sum_error_common() const override {
    return options_.tolerance + kFloatStorageRowError;
  }
  double row_sum_allowance(size_t i) const override {
    return kRowSamplingSigmas * row_sampling_error(i) + row_quadrature_excess(i);
  }
  std::optional<double> stated_reciprocity_error() const override;
  // The ".sigma" side file (save_/load_row_sampling_errors below); a matrix loaded without it is
  // still used, the rows the check needs being recomputed.
  void save_side_files(const std::string& matrix_file) const override {
    save_row_sampling_errors(*this, matrix_file);
  }
  bool load_side_files(const std::string& matrix_file, size_t n) const override {
    load_row_sampling_errors(*this, matrix_file, n);
    return true;
  }
  std::vector<RowSideFile> row_side_files() const override { return {{".sigma", 2}}; }
  // Blocks of pairs (form_factor_method.h): each pair's quadrature and visibility once for both
  // entries. Each row's sampling variance and quadrature excess are sums over its pairs kept in
  // fixed point (formfactor/matrix/fixed_sum.h: exact and associative), so a row's sums come out
  // the same bits whether one process adds them in column order or blocks add their shares.
  bool builds_in_row_blocks() const override { return false; }
  bool builds_in_pair_blocks() const override { return true; }
  void pair_entries(size_t i, std::span<double> upper, std::span<double> lower,
                    RowCost& cost) const override;
  // Each row's pairs' expected work in ray-equivalents from every kWorkSample-th of them:
  // raycast.cpp, pair_work.
  PairWork pair_work() const override;
  size_t pair_block_state_bytes(size_t n) const override { return n * kRowStateBytes; }
  std::vector<char> pair_block_state() const override;
  bool restore_pair_block_states(const std::vector<std::vector<char>>& states) const override;

  // One pair, for tests and the catalogue comparisons.
  double pair(size_t i, size_t j, RowCost& cost) const;
  bool casts_rays() const { return visibility_.casts_rays(); }
  // F^u_ij, the pair without visibility (0 when it faces away or is coplanar), for diagnostics.
  double unoccluded_pair(size_t i, size_t j) const override;
  // The standard error of row i's sum from the visibility sampling, sqrt(sum_j (F^u_ij
  // sigma(V_ij))^2) (pairs are traced independently), known once row i has been computed (a
  // build of every row); a row not yet computed (a matrix loaded from the cache) is computed
  // here once to find it. Thread-safe for distinct rows.
  double row_sampling_error(size_t i) const;
  // The largest row_sampling_error over the rows computed so far (0 when none).
  double largest_row_sampling_error() const;
  // Every row's sampling error as known (NaN for rows not computed), and the same restored
  // (for a matrix loaded from the cache: its rows' errors kept beside it, so the row-sum check
  // need not recompute rows; save_/load_row_sampling_errors). Not thread-safe.
  std::vector<float> row_sampling_errors() const { return row_sigma_; }
  void set_row_sampling_errors(std::vector<float> sigma) const;
  // What row i's F^u integrals left beyond their tolerance, sum_j max(0, e_ij - tolerance F^u_ij)
  // with e_ij the adaptive rule's estimated error (polygon_integral.h): nonzero only where an
  // integral stopped at its depth limit or at a work cap (raycast.cpp), and added to the row's
  // stated error (diagnostics.h). Known, like row_sampling_error, once the row has been computed;
  // computed here otherwise. Thread-safe for distinct rows.
  double row_quadrature_excess(size_t i) const;
  double largest_row_quadrature_excess() const;
  // The pairs (ordered, over the rows computed) whose integral stopped short of the tolerance.
  size_t pairs_short_of_tolerance() const;
  std::vector<float> row_quadrature_excesses() const { return row_excess_; }
  void set_row_quadrature_excesses(std::vector<float> excess) const;
  // The order of the Gauss rule the pair's F^u uses (order x order points per fan triangle or
  // quad), or 0 when it goes adaptive or has nothing in front of j's plane. For benchmarks.
  int fixed_order(size_t i, size_t j) const;

 private:
  // F^u_ij; `error`, if given, receives the quadrature's estimated error of it.
  double unoccluded(size_t i, size_t j, RowCost& cost, double* error = nullptr) const;
  // Computes row i once if its sampling error or quadrature excess is not known yet.
  void ensure_row_errors(size_t i) const;
  // F^u_ij by the integral over i (unoccluded() chooses the side).
  double unoccluded_over(size_t i, size_t j, RowCost& cost, double* error) const;
  // F_ij, the variance of its visibility estimate and what its quadrature left beyond the
  // tolerance (row_quadrature_excess).
  double pair_with_errors(size_t i, size_t j, RowCost& cost, double& variance,
                          double& excess) const;
  int order_for(size_t i, size_t j, std::span<const Vec3> from, double kept) const;
  // F^u_ij and F^u_ji with their quadrature errors, the same bits as unoccluded(i, j) and
  // unoccluded(j, i), from one integral when both integrate over the same side (always, unless
  // an element has no area).
  void unoccluded_both(size_t i, size_t j, RowCost& cost, double& f_ij, double& error_ij,
                       double& f_ji, double& error_ji) const;
  // A row's sums in fixed point (raycast.cpp): variance, quadrature excess, pairs short of the
  // tolerance; stored into row_sigma_, row_excess_ and row_short_ as row() stores them.
  struct RowSums;
  void finish_row(size_t i, const RowSums& sums) const;
  // Per row: low and high words of the two fixed-point sums, and the short pairs (8 bytes each).
  static constexpr size_t kRowStateBytes = 5 * sizeof(uint64_t);

  const Mesh& mesh_;
  RaycastOptions options_;
  FixedOrderRule order_rule_;
  double plane_epsilon_ = 0.0;
  std::vector<double> radius_;  // largest centroid-to-corner distance per element
  Visibility visibility_;
  mutable std::vector<float> row_sigma_;     // per row: row_sampling_error, NaN until computed
  mutable std::vector<float> row_excess_;    // per row: row_quadrature_excess, NaN until computed
  mutable std::vector<uint32_t> row_short_;  // per row: its pairs short of the tolerance
  // pair_entries: every row's share of the pairs computed so far (kRowStateBytes / 8 words a
  // row, added atomically: a pair (i, j) adds to row j from row i's task).
  mutable std::unique_ptr<std::atomic<uint64_t>[]> pair_sums_;
};

// Each row's visibility sampling error and quadrature excess beside a cached matrix file
// (`matrix_file` + ".sigma": 2n floats, the n errors then the n excesses, behind the matrix
// file's header and key and under a checksum: write_matrix_side_file in
// formfactor/matrix/matrix_cache.h). Saved only beside a valid cache file. load_ returns false
// (and changes nothing) when the file is missing, of the wrong size, unreadable, damaged, or
// written beside another matrix or an earlier build: the rows are then recomputed when the
// check needs them.
void save_row_sampling_errors(const RaycastFormFactors& method, const std::string& matrix_file);
bool load_row_sampling_errors(const RaycastFormFactors& method, const std::string& matrix_file,
                              size_t n);

// False when j lies wholly behind or in i's plane, or i wholly behind or in j's (up to
// `epsilon` metres): such a pair exchanges no light and costs nothing.
bool pair_faces(const Mesh& mesh, size_t i, size_t j, double epsilon);

}  // namespace radlab
