// The built hierarchy of hierarchical radiosity: the nodes that refinement made (every input
// chart's quadtree, each interior node with all its children), their radiosities, and the links
// stored per receiving node for gathering; the Gather and PushPull of Hanrahan, Salzman &
// Aupperle 1991 (§5.1), and the projection onto the run's element mesh (hierarchical_tree.h).
//
// With clusters (hierarchical_clusters.h), nodes 0 .. clusters-1 are the clusters in preorder
// (parents first) and the quadtree nodes follow: a chart's root has its cluster as parent, a
// cluster its two children (clusters or chart roots). A cluster gathers like any node; what it
// gathers is pushed down to all its charts (Sillion 1995's isotropic push: the same irradiance for
// every member), and its B is the area average of its children's (pull), which is what its links
// send. Oriented clusters push and pull per orientation instead (Hierarchy::slots below).
//
// Nodes are numbered in depth-first key order (hierarchical_tree.h), charts contiguous, so the
// same links give the same numbering, sums in the same order, and the same bits on any number of
// threads: gathers run in parallel over receiving nodes, push/pull over charts, projection over
// elements, each writing only its own values.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/radiosity.h"
#include "solvers/hierarchical/hierarchical_clusters.h"
#include "solvers/hierarchical/hierarchical_refine.h"
#include "solvers/hierarchical/hierarchical_tree.h"

namespace radlab::hier {

struct Hierarchy {
  int channels = 1;
  std::vector<NodeKey> key;
  std::vector<int32_t> parent;
  std::vector<std::array<int32_t, 4>> child;  // -1: none (a leaf has none)
  std::vector<double> area;
  std::vector<uint32_t> chart_first;  // charts + 1 offsets: nodes of chart c
  std::unordered_map<NodeKey, uint32_t, NodeKeyHash> index;
  // Channel-major per-node values: value(c, i) = v[c * size() + i].
  std::vector<double> B, gathered, emission, reflectance;
  // Links per receiver (CSR): node i gathers factor[k] * B[source[k]] for k in
  // [first[i], first[i+1]).
  std::vector<uint64_t> first;
  std::vector<uint32_t> source;
  std::vector<double> factor;
  std::vector<uint8_t> free_rays;  // per CSR entry: the link's unblocked rays (V = free / 16)
  // Per node: the factor every leaf applies to what it and its ancestors gathered (1 until
  // normalise_rows sets it; hierarchical_rows.h).
  std::vector<double> row_scale;
  // Per leaf and channel (channel-major, 0 elsewhere): what the leaf adds to row_scale times its
  // path's gathered light so that the emitted part of it is received by the leaf's own rule
  // rather than scaled with the reflected part (hierarchical_rows.h).
  std::vector<double> row_offset;
  // Column balance (rows=balanced; hierarchical_rows.h): per node, the factor t on the reflected
  // light a leaf sends through links (1 on interior nodes), and the values the links read,
  // S = E + t (B - E) at leaves and area averages above (channel-major). Both empty otherwise:
  // the links read B itself.
  std::vector<double> send_scale, S;
  // Per-orientation push and pull through oriented clusters (enable_orientation_slots; all
  // empty otherwise). A cluster's slots (hierarchical_clusters.h: one per kept normal, one for
  // the remainder) each hold the area average of their charts' sent light (slot_sent, pulled
  // before every gather; slot_emission likewise for E), and what the cluster gathers is shared
  // among its slots in proportion to their projected area toward each link's source
  // (slot_gathered, per unit area), then pushed to each chart through its own slot: a face of
  // the cluster turned away from a source gets none of its light. A link from a cluster source
  // reads its slots weighted by their projected areas toward the receiver (the light the
  // cluster's faces send that way), not the cluster's area average. Channel-major over slots.
  bool slots = false;
  std::vector<double> slot_sent, slot_gathered, slot_emission;
  std::vector<Vec3> node_centre;  // per node (slots only): a cluster's centre, a node's centroid
  // With row normalisation (normalise_rows fills them; hierarchical_rows.h) every leaf gathers
  // the links at the clusters on its path itself, each by the leaf's own rule (its 2 x 2
  // points' kernel, V included: the per-element evaluation of Smits, Arvo & Greenberg 1994's
  // beta links), and the clusters push nothing: leaf i's links are the CSR entries
  // leaf_link_entry[leaf_link_first[i] .. leaf_link_first[i+1]) with the leaf's factors
  // leaf_link_factor; each pass a cluster's gather stores what each of its links carries (the
  // source's light toward the cluster) in link_value (channel-major over the clusters' CSR
  // entries, first[clusters] per channel). Empty (rows=links): the slots' push above.
  std::vector<uint64_t> leaf_link_first;
  std::vector<uint32_t> leaf_link_entry;
  std::vector<double> leaf_link_factor, link_value;
  bool leaf_rule() const { return !leaf_link_first.empty(); }
  size_t leaves = 0;
  size_t clusters = 0;                        // nodes [0, clusters) are clusters
  std::vector<Vec3> cluster_centre;           // per cluster
  const ClusterTree* cluster_tree = nullptr;  // the clusters' tree (nullptr: none)

  size_t size() const { return key.size(); }
  bool balanced() const { return !send_scale.empty(); }
  // What links read: S with column balance, else B.
  const std::vector<double>& sent() const { return balanced() ? S : B; }
  bool is_leaf(size_t i) const { return child[i][0] < 0; }
  double& b(int c, size_t i) { return B[size_t(c) * size() + i]; }
  double b(int c, size_t i) const { return B[size_t(c) * size() + i]; }
  // B of the deepest existing node at or above `k` (a node not in the tree has its leaf
  // ancestor's constant value).
  Rgb radiosity(const NodeKey& k) const;
  size_t memory_bytes() const;
};

// Builds the tree holding every chart root and both ends of every link (with their ancestors
// and siblings), and every cluster of `clusters` (nullptr or empty: none). Radiosities carry over
// from `previous` (deepest existing ancestor; E where there is none; a cluster's E is its charts'
// area average). chart_emission/chart_reflectance: per chart, `channels` values used.
Hierarchy build_hierarchy(const std::vector<Chart>& charts, const std::vector<LinkRecord>& links,
                          const Hierarchy* previous, const std::vector<Rgb>& chart_emission,
                          const std::vector<Rgb>& chart_reflectance, int channels,
                          const ClusterTree* clusters = nullptr);

// Turns on the per-orientation push and pull (above) for a hierarchy with oriented clusters;
// `charts` gives the nodes' centres. Without column balance only (rows=balanced scales the
// area-average push/pull).
void enable_orientation_slots(Hierarchy& h, const std::vector<Chart>& charts);
// The light cluster `cluster` sends in the unit direction w, per unit of its projected area
// that way (out: one value per channel): its slots' values (`slot_values`) weighted by their
// projected areas toward w; the slots' area average where none faces w.
void slot_directional(const Hierarchy& h, const std::vector<double>& slot_values, uint32_t cluster,
                      const Vec3& w, double* out);
// The factor on a link to cluster `cluster` (from the unit direction u towards its source) that
// its slot `slot` receives per unit area, per unit of the link's factor: the slot's projected
// area toward u over its area, over the cluster's projected area toward u over the cluster's
// area (so the slots' area-weighted shares sum to 1: power is conserved). 1 where the cluster
// shows nothing toward u.
double slot_share(const Hierarchy& h, uint32_t cluster, uint32_t slot, const Vec3& u);

// Recomputes S from B and send_scale for nodes [begin, end) (children after their parents in
// index order, so a descending sweep sees every child first). No-op without column balance.
void refresh_sent(Hierarchy& h, size_t begin, size_t end);

// One Jacobi pass: every node gathers from the previous B, then push/pull sets the new B.
// Returns the largest change of a leaf radiosity (any channel).
double jacobi_pass(Hierarchy& h);
// One Gauss–Seidel pass: chart after chart, gather (newest B) then push/pull in place.
double gauss_seidel_pass(Hierarchy& h);

// The area average of the leaves over every mesh element.
void project(const Hierarchy& h, const std::vector<Chart>& charts,
             const std::vector<ElementChart>& elements, Radiosity& out);

}  // namespace radlab::hier
