// Link refinement of hierarchical radiosity: Refine(p, q, feps, aeps) of Hanrahan, Salzman &
// Aupperle 1991 (§3), with their visibility coherence (§4), BF refinement and multigridding
// (§5.2).
//
// Estimate: the unoccluded form factor from the centre of one node to the other node, by
// Lambert's exact point-to-polygon formula (formfactor/integrate/point_polygon.h), both ways. The
// paper names a disk or bounding-sphere solid angle; the Lambert value costs about the same, is
// exact for the differential area at the centre (so it already contains both nodes' orientations,
// which a disk of the same area facing the point ignores), and its error against the area-to-area
// form factor is O((r/R)^2) relative, the same order the paper's analysis uses. Where one node is
// cut by the other's plane the centre may see none of the other node while the rest of it does, so
// the estimate is then the larger of the centre value and the facing disk's A/(pi R^2 + A).
//
// Link when both estimates (times B_q rho_p / B_scale under BF refinement, and times
// kPartialPenalty for partially visible or plane-cut pairs, whose visibility estimate is less
// certain: the paper's larger error at shadow boundaries) are below feps; else split the node
// seen the larger (the one with the larger estimate from the other) if its area is at least
// aeps and its depth below kMaxDepth, else link anyway.
//
// A link's transfer factor: V times the mean of the point-to-polygon form factor over the
// centres of the receiving node's four children (a 2 x 2 rule: where a node's own plane cuts the
// other, it sees part of it, which the centre alone can miss), each way. V is the unblocked
// fraction of 16 rays (hierarchical_visibility.h); totally occluded pairs are neither linked nor
// refined; a fully visible pair's descendants inherit V = 1 without rays.
//
// Work charged: 2 element-pair form factors per refinement test (the two estimates) and 2 per
// link (its two transfer factors).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "solvers/hierarchical/hierarchical_tree.h"
#include "solvers/hierarchical/hierarchical_visibility.h"

namespace radlab::hier {

enum class LinkClass : uint8_t { kVisible = 0, kPartial = 1, kCut = 2 };

// A link between nodes p and q: p gathers fpq * B_q, q gathers fqp * B_p.
struct LinkRecord {
  NodeKey p, q;
  double fpq = 0.0, fqp = 0.0;             // transfer factors, visibility included
  float estimate_pq = 0, estimate_qp = 0;  // unoccluded estimates (the refinement oracle)
  LinkClass cls = LinkClass::kVisible;
  bool partial = false;    // some rays blocked (a cut pair can be partial too)
  uint8_t free_rays = 16;  // unblocked rays of kVisibilityRays: V = free_rays / 16
};

// Counters of the paper's Table 1.
struct RefineStats {
  uint64_t refinement_tests = 0;   // Refine calls that evaluated estimates
  uint64_t facing_away = 0;        // pairs dropped by the plane test
  uint64_t visibility_tests = 0;   // pairs that cast rays
  uint64_t inherited_visible = 0;  // pairs that took V = 1 from a fully visible ancestor pair
  uint64_t occluded = 0;           // pairs found totally occluded (neither linked nor refined)
  uint64_t degenerate = 0;         // pairs with a node of zero area (neither linked nor refined)
  uint64_t rays = 0;
  uint64_t pair_evaluations = 0;
  uint64_t links_created = 0;

  void add(const RefineStats& o);
};

// The partially visible pairs' error multiplier.
inline constexpr double kPartialPenalty = 4.0;

struct RefineCriterion {
  double feps = 0.02;
  double min_area = 0.0;  // aeps in scene units (m^2)
  uint64_t seed = 1;
  // BF refinement: the oracle is estimate * max_c rho_p,c B_q,c / bf_scale (the scene's mean
  // radiosity). Empty: F alone.
  std::function<Rgb(const NodeKey&)> radiosity;
  std::vector<Rgb> chart_reflectance;  // per chart (BF only)
  double bf_scale = 1.0;
};

class Refiner {
 public:
  Refiner(const std::vector<Chart>& charts, const NodeVisibility& visibility,
          const RefineCriterion& criterion)
      : charts_(charts), visibility_(visibility), c_(criterion) {}

  // Refine(root of chart a, root of chart b).
  void refine_roots(uint32_t a, uint32_t b, std::vector<LinkRecord>& out, RefineStats& stats) const;
  // Multigridding: keeps `link` if it passes the (new) criterion, else replaces it by the links
  // Refine makes below it.
  void rerefine(const LinkRecord& link, std::vector<LinkRecord>& out, RefineStats& stats) const;

 private:
  struct Node {
    NodeKey key;
    NodeGeometry g;
  };
  enum class Known : uint8_t { kUnknown, kVisible };

  void refine(const Node& p, const Node& q, Known known, std::vector<LinkRecord>& out,
              RefineStats& stats) const;
  double error(const NodeKey& receiver, const NodeKey& source, double estimate) const;
  bool can_split(const Node& n) const;
  void split(const Node& p, const Node& q, bool split_q, Known known, std::vector<LinkRecord>& out,
             RefineStats& stats) const;
  double transfer(const Node& receiver, const Node& source) const;
  double max_over_children(const Node& receiver, const Node& source) const;

  const std::vector<Chart>& charts_;
  const NodeVisibility& visibility_;
  RefineCriterion c_;
};

}  // namespace radlab::hier
