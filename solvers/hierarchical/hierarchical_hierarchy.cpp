#include "solvers/hierarchical/hierarchical_hierarchy.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <unordered_set>

namespace radlab::hier {

Rgb Hierarchy::radiosity(const NodeKey& k) const {
  NodeKey at = k;
  for (;;) {
    auto it = index.find(at);
    if (it != index.end()) {
      const size_t i = it->second;
      if (channels == 1) return Rgb(b(0, i));
      return {b(0, i), b(1, i), b(2, i)};
    }
    if (at.depth == 0) return Rgb(0.0);
    at = at.parent();
  }
}

size_t Hierarchy::memory_bytes() const {
  const size_t per_node = sizeof(NodeKey) + sizeof(int32_t) + sizeof(std::array<int32_t, 4>) +
                          sizeof(double) + 5 * sizeof(double) * size_t(channels) +
                          sizeof(uint64_t) +
                          // the key index: a node, its key and a bucket pointer
                          sizeof(NodeKey) + sizeof(uint32_t) + 2 * sizeof(void*);
  return size() * (per_node + sizeof(double)) + clusters * sizeof(Vec3) +
         (send_scale.size() + S.size()) * sizeof(double) +
         source.size() * (sizeof(uint32_t) + sizeof(double) + sizeof(uint8_t)) +
         (slot_sent.size() + slot_gathered.size() + slot_emission.size()) * sizeof(double) +
         node_centre.size() * sizeof(Vec3) + leaf_link_first.size() * sizeof(uint64_t) +
         leaf_link_entry.size() * (sizeof(uint32_t) + sizeof(double)) +
         link_value.size() * sizeof(double);
}

Hierarchy build_hierarchy(const std::vector<Chart>& charts, const std::vector<LinkRecord>& links,
                          const Hierarchy* previous, const std::vector<Rgb>& chart_emission,
                          const std::vector<Rgb>& chart_reflectance, int channels,
                          const ClusterTree* clusters) {
  Hierarchy h;
  h.channels = channels;
  const size_t NC = clusters ? clusters->size() : 0;
  std::unordered_set<NodeKey, NodeKeyHash> set;
  set.reserve(charts.size() + 2 * links.size());
  for (uint32_t c = 0; c < charts.size(); ++c) set.insert({c, 0, 0});
  std::vector<NodeKey> pending;
  auto add_with_ancestors = [&](NodeKey k) {
    if (k.is_cluster()) return;  // every cluster is a node anyway
    while (set.insert(k).second && k.depth > 0) k = k.parent();
  };
  for (const LinkRecord& l : links) {
    add_with_ancestors(l.p);
    add_with_ancestors(l.q);
  }
  // Every interior node gets all its children (the leaves must cover each chart).
  pending.assign(set.begin(), set.end());
  for (const NodeKey& k : pending)
    if (k.depth > 0) {
      const NodeKey parent = k.parent();
      for (int d = 0; d < 4; ++d) set.insert(parent.child(d));
    }
  h.key.assign(set.begin(), set.end());
  std::sort(h.key.begin(), h.key.end(), dfs_less);
  if (NC > 0) {
    std::vector<NodeKey> keys(NC);
    for (size_t c = 0; c < NC; ++c) keys[c] = NodeKey::cluster(uint32_t(c));
    keys.insert(keys.end(), h.key.begin(), h.key.end());
    h.key.swap(keys);
  }
  h.clusters = NC;
  const size_t n = h.key.size();
  h.index.reserve(n);
  for (size_t i = 0; i < n; ++i) h.index.emplace(h.key[i], uint32_t(i));
  h.parent.assign(n, -1);
  h.child.assign(n, {-1, -1, -1, -1});
  h.chart_first.assign(charts.size() + 1, uint32_t(n));
  for (size_t i = n; i-- > NC;) h.chart_first[h.key[i].chart] = uint32_t(i);
  h.area.resize(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(NC, n, 512),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i)
                        h.area[i] = node_geometry(charts, h.key[i]).area;
                    });
  for (size_t i = NC; i < n; ++i) {
    const NodeKey& k = h.key[i];
    if (k.depth == 0) continue;
    const uint32_t p = h.index.at(k.parent());
    h.parent[i] = int32_t(p);
    h.child[p][size_t(k.digit(k.depth))] = int32_t(i);
  }
  // Clusters: parents, children (a chart child is its root node) and areas, children first.
  h.cluster_centre.resize(NC);
  h.cluster_tree = NC > 0 ? clusters : nullptr;
  for (size_t c = 0; c < NC; ++c) {
    const Cluster& cl = clusters->clusters[c];
    h.parent[c] = cl.parent;
    h.cluster_centre[c] = cl.centre;
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = cl.child[k];
      const size_t node = ch >= 0 ? size_t(ch) : size_t(h.chart_first[size_t(~ch)]);
      h.child[c][size_t(k)] = int32_t(node);
      h.parent[node] = int32_t(c);
    }
  }
  for (size_t c = NC; c-- > 0;)
    h.area[c] = h.area[size_t(h.child[c][0])] + h.area[size_t(h.child[c][1])];
  h.leaves = 0;
  for (size_t i = 0; i < n; ++i) h.leaves += h.is_leaf(i) ? 1 : 0;

  const size_t C = size_t(channels);
  h.B.assign(C * n, 0.0);
  h.gathered.assign(C * n, 0.0);
  h.emission.assign(C * n, 0.0);
  h.reflectance.assign(C * n, 0.0);
  for (size_t i = h.clusters; i < n; ++i) {
    const uint32_t chart = h.key[i].chart;
    const Rgb b = previous ? previous->radiosity(h.key[i]) : chart_emission[chart];
    for (size_t c = 0; c < C; ++c) {
      h.emission[c * n + i] = chart_emission[chart][int(c)];
      h.reflectance[c * n + i] = chart_reflectance[chart][int(c)];
      h.B[c * n + i] = b[int(c)];
    }
  }
  // A cluster's E is its children's area average (so what its links send, the pull of B, splits
  // into emitted and reflected light as a surface's does; hierarchical_rows.h); its reflectance
  // is unused (clusters are never leaves).
  for (size_t k = h.clusters; k-- > 0;) {
    const size_t a = size_t(h.child[k][0]), b = size_t(h.child[k][1]);
    const double area = h.area[a] + h.area[b];
    const Rgb carried = previous ? previous->radiosity(h.key[k]) : Rgb(0.0);
    for (size_t c = 0; c < C; ++c) {
      const double e =
          area > 0.0
              ? (h.area[a] * h.emission[c * n + a] + h.area[b] * h.emission[c * n + b]) / area
              : 0.0;
      h.emission[c * n + k] = e;
      h.B[c * n + k] = previous ? carried[int(c)] : e;
    }
  }

  // Links per receiver, in link order.
  h.first.assign(n + 1, 0);
  std::vector<std::array<uint32_t, 2>> ends(links.size());
  for (size_t l = 0; l < links.size(); ++l) {
    ends[l] = {h.index.at(links[l].p), h.index.at(links[l].q)};
    ++h.first[ends[l][0] + 1];
    ++h.first[ends[l][1] + 1];
  }
  for (size_t i = 0; i < n; ++i) h.first[i + 1] += h.first[i];
  h.source.resize(2 * links.size());
  h.factor.resize(2 * links.size());
  h.free_rays.resize(2 * links.size());
  h.row_scale.assign(n, 1.0);
  h.row_offset.assign(C * n, 0.0);
  std::vector<uint64_t> fill(h.first.begin(), h.first.end() - 1);
  for (size_t l = 0; l < links.size(); ++l) {
    const auto [p, q] = ends[l];
    h.source[fill[p]] = q;
    h.free_rays[fill[p]] = links[l].free_rays;
    h.factor[fill[p]++] = links[l].fpq;
    h.source[fill[q]] = p;
    h.free_rays[fill[q]] = links[l].free_rays;
    h.factor[fill[q]++] = links[l].fqp;
  }
  return h;
}

namespace {

// The unit vector along d; zero for d = 0 (coincident centres: no slot faces anywhere, so the
// slots' area average and equal shares are used).
Vec3 unit(const Vec3& d) {
  const double length = std::sqrt(glm::dot(d, d));
  return length > 0.0 ? d / length : Vec3(0.0);
}

// Per slot, the area average of its charts' roots' `values` (channel-major per node); the same
// sums in chart order whatever the threads.
void pull_slots(const Hierarchy& h, const std::vector<double>& values, std::vector<double>& out) {
  const ClusterTree& t = *h.cluster_tree;
  const size_t S = t.slot_area.size(), n = h.size(), charts = h.chart_first.size() - 1;
  out.assign(size_t(h.channels) * S, 0.0);
  std::vector<double> weight(S, 0.0);
  for (size_t c = 0; c < charts; ++c) {
    const size_t root = h.chart_first[c];
    const double a = h.area[root];
    for (uint32_t k = t.chart_slot_first[c]; k < t.chart_slot_first[c + 1]; ++k) {
      const size_t slot = t.chart_slot[k];
      weight[slot] += a;
      for (int ch = 0; ch < h.channels; ++ch)
        out[size_t(ch) * S + slot] += a * values[size_t(ch) * n + root];
    }
  }
  for (size_t slot = 0; slot < S; ++slot)
    for (int ch = 0; ch < h.channels; ++ch)
      out[size_t(ch) * S + slot] =
          weight[slot] > 0.0 ? out[size_t(ch) * S + slot] / weight[slot] : 0.0;
}

// Gathers with per-orientation pull and push (Hierarchy::slots): a cluster source is read
// toward the receiver, a cluster receiver shares each link's light among its slots.
void gather_slotted(Hierarchy& h, size_t begin, size_t end) {
  const size_t n = h.size();
  const ClusterTree& t = *h.cluster_tree;
  const size_t S = t.slot_area.size();
  const size_t E = h.first[h.clusters];  // the CSR entries of the clusters' links
  const std::vector<double>& sent = h.sent();
  auto gather = [&](size_t i) {
    const bool cluster = i < h.clusters;
    if (!cluster) {
      // A node: its links from nodes channel by channel, as gather_range does (the bulk of the
      // work), then those from clusters, read toward it, then its clusters' links by its own
      // rule.
      double sum[3] = {0.0, 0.0, 0.0};
      for (int c = 0; c < h.channels; ++c) {
        const double* B = sent.data() + size_t(c) * n;
        double acc = 0.0;
        for (uint64_t k = h.first[i]; k < h.first[i + 1]; ++k)
          if (h.source[k] >= h.clusters) acc += h.factor[k] * B[h.source[k]];
        sum[c] = acc;
      }
      for (uint64_t k = h.first[i]; k < h.first[i + 1]; ++k) {
        const uint32_t s = h.source[k];
        if (s >= h.clusters) continue;
        double value[3] = {0.0, 0.0, 0.0};
        slot_directional(h, h.slot_sent, s, unit(h.node_centre[i] - h.node_centre[s]), value);
        for (int c = 0; c < h.channels; ++c) sum[c] += h.factor[k] * value[c];
      }
      if (h.leaf_rule())
        for (uint64_t k = h.leaf_link_first[i]; k < h.leaf_link_first[i + 1]; ++k)
          for (int c = 0; c < h.channels; ++c)
            sum[c] += h.leaf_link_factor[k] * h.link_value[size_t(c) * E + h.leaf_link_entry[k]];
      for (int c = 0; c < h.channels; ++c) h.gathered[size_t(c) * n + i] = sum[c];
      return;
    }
    const bool push = cluster && !h.leaf_rule();
    const uint32_t s0 = push ? t.slot_first[i] : 0, s1 = push ? t.slot_first[i + 1] : 0;
    for (int c = 0; c < h.channels; ++c)
      for (uint32_t j = s0; j < s1; ++j) h.slot_gathered[size_t(c) * S + j] = 0.0;
    double sum[3] = {0.0, 0.0, 0.0};
    for (uint64_t k = h.first[i]; k < h.first[i + 1]; ++k) {
      const uint32_t s = h.source[k];
      double value[3] = {0.0, 0.0, 0.0};
      if (s < h.clusters)
        slot_directional(h, h.slot_sent, s, unit(h.node_centre[i] - h.node_centre[s]), value);
      else
        for (int c = 0; c < h.channels; ++c) value[c] = sent[size_t(c) * n + s];
      if (cluster && h.leaf_rule()) {
        // What this link carries, read by the leaves below with their own factors.
        for (int c = 0; c < h.channels; ++c) h.link_value[size_t(c) * E + k] = value[c];
        continue;
      }
      for (int c = 0; c < h.channels; ++c) sum[c] += h.factor[k] * value[c];
      if (!push) continue;
      // slot_share for every slot, the cluster's projected area taken once.
      const Vec3 u = unit(h.node_centre[s] - h.node_centre[i]);
      const double projected = t.projected_area(uint32_t(i), u);
      const double scale = projected > 0.0 ? t.clusters[i].area / projected : 0.0;
      for (uint32_t j = s0; j < s1; ++j) {
        const double area = t.slot_area[j];
        const double share = !(projected > 0.0) ? 1.0
                             : area > 0.0 ? t.slot_projected_area(uint32_t(i), j, u) / area * scale
                                          : 0.0;
        const double f = h.factor[k] * share;
        for (int c = 0; c < h.channels; ++c) h.slot_gathered[size_t(c) * S + j] += f * value[c];
      }
    }
    for (int c = 0; c < h.channels; ++c) h.gathered[size_t(c) * n + i] = sum[c];
  };
  // The clusters first: their links' values are what the leaves read.
  const size_t mid = std::clamp(h.clusters, begin, end);
  for (const auto& [from, to] : {std::pair{begin, mid}, std::pair{mid, end}})
    tbb::parallel_for(tbb::blocked_range<size_t>(from, to, 256),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t i = r.begin(); i < r.end(); ++i) gather(i);
                      });
}

// Per chart, what its clusters pass down to its root through its own slots (3 per chart).
std::vector<double> slot_down(const Hierarchy& h) {
  const ClusterTree& t = *h.cluster_tree;
  const size_t S = t.slot_area.size(), charts = h.chart_first.size() - 1;
  std::vector<double> down(3 * charts, 0.0);
  if (h.leaf_rule()) return down;  // the leaves gathered the clusters' links themselves
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, charts, 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t c = r.begin(); c < r.end(); ++c)
          for (uint32_t k = t.chart_slot_first[c]; k < t.chart_slot_first[c + 1]; ++k)
            for (int ch = 0; ch < h.channels; ++ch)
              down[3 * c + size_t(ch)] += h.slot_gathered[size_t(ch) * S + t.chart_slot[k]];
      });
  return down;
}

void gather_range(Hierarchy& h, size_t begin, size_t end) {
  if (h.slots) {
    gather_slotted(h, begin, end);
    return;
  }
  const size_t n = h.size();
  tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, 256),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i)
                        for (int c = 0; c < h.channels; ++c) {
                          const double* B = h.sent().data() + size_t(c) * n;
                          double sum = 0.0;
                          for (uint64_t k = h.first[i]; k < h.first[i + 1]; ++k)
                            sum += h.factor[k] * B[h.source[k]];
                          h.gathered[size_t(c) * n + i] = sum;
                        }
                    });
}

// PushPull on the subtree at i: `down` is what the ancestors gathered; writes the new B into
// `out`; returns the largest leaf change against the current B.
double push_pull(const Hierarchy& h, size_t i, const double* down, std::vector<double>& out) {
  const size_t n = h.size();
  double total[3] = {0.0, 0.0, 0.0};
  for (int c = 0; c < h.channels; ++c) total[c] = down[c] + h.gathered[size_t(c) * n + i];
  double change = 0.0;
  if (h.is_leaf(i)) {
    for (int c = 0; c < h.channels; ++c) {
      const size_t at = size_t(c) * n + i;
      out[at] = h.emission[at] + h.reflectance[at] * (h.row_scale[i] * total[c] + h.row_offset[at]);
      change = std::max(change, std::abs(out[at] - h.B[at]));
    }
    return change;
  }
  double sum[3] = {0.0, 0.0, 0.0}, area = 0.0;
  for (int32_t k : h.child[i]) {
    if (k < 0) continue;
    change = std::max(change, push_pull(h, size_t(k), total, out));
    area += h.area[size_t(k)];
    for (int c = 0; c < h.channels; ++c)
      sum[c] += h.area[size_t(k)] * out[size_t(c) * n + size_t(k)];
  }
  for (int c = 0; c < h.channels; ++c) out[size_t(c) * n + i] = sum[c] / area;
  return change;
}

// What every cluster passes down to its charts: its own gathered light and its ancestors'
// (channel-major per cluster, 3 slots), parents first.
std::vector<double> cluster_down(const Hierarchy& h) {
  const size_t n = h.size();
  std::vector<double> down(3 * h.clusters, 0.0);
  for (size_t k = 0; k < h.clusters; ++k)
    for (int c = 0; c < h.channels; ++c) {
      const double above = h.parent[k] >= 0 ? down[3 * size_t(h.parent[k]) + size_t(c)] : 0.0;
      down[3 * k + size_t(c)] = above + h.gathered[size_t(c) * n + k];
    }
  return down;
}

// Pull through the clusters, children first: B is the area average of the children's.
void pull_clusters(const Hierarchy& h, std::vector<double>& out) {
  const size_t n = h.size();
  for (size_t k = h.clusters; k-- > 0;) {
    const size_t a = size_t(h.child[k][0]), b = size_t(h.child[k][1]);
    const double area = h.area[a] + h.area[b];
    for (int c = 0; c < h.channels; ++c) {
      const size_t o = size_t(c) * n;
      out[o + k] = area > 0.0 ? (h.area[a] * out[o + a] + h.area[b] * out[o + b]) / area : 0.0;
    }
  }
}

// What clusters pass down: per cluster (cluster_down), or per chart through its slots.
std::vector<double> clusters_down(const Hierarchy& h) {
  return h.slots ? slot_down(h) : cluster_down(h);
}

// The light chart c's root receives from above: nothing without clusters.
const double* chart_down(const Hierarchy& h, const std::vector<double>& down, size_t chart) {
  static const double zero[3] = {0.0, 0.0, 0.0};
  if (h.slots) return down.data() + 3 * chart;
  const int32_t parent = h.parent[h.chart_first[chart]];
  return parent >= 0 ? down.data() + 3 * size_t(parent) : zero;
}

}  // namespace

void refresh_sent(Hierarchy& h, size_t begin, size_t end) {
  if (!h.balanced()) return;
  const size_t n = h.size();
  for (size_t i = end; i-- > begin;)
    for (int c = 0; c < h.channels; ++c) {
      const size_t at = size_t(c) * n + i;
      if (h.is_leaf(i)) {
        const double t = h.send_scale[i];
        h.S[at] = t == 1.0 ? h.B[at] : h.emission[at] + t * (h.B[at] - h.emission[at]);
        continue;
      }
      // The same sums, in the same order, as push/pull's and pull_clusters' averages of B, so
      // that S equals B bit for bit where every t is 1.
      double sum = 0.0, area = 0.0;
      for (int32_t k : h.child[i]) {
        if (k < 0) continue;
        area += h.area[size_t(k)];
        sum += h.area[size_t(k)] * h.S[size_t(c) * n + size_t(k)];
      }
      h.S[at] = area > 0.0 ? sum / area : 0.0;
    }
}

void enable_orientation_slots(Hierarchy& h, const std::vector<Chart>& charts) {
  if (!h.cluster_tree || !h.cluster_tree->oriented() || h.balanced()) return;
  h.slots = true;
  const size_t S = h.cluster_tree->slot_area.size(), n = h.size();
  h.slot_sent.assign(size_t(h.channels) * S, 0.0);
  h.slot_gathered.assign(size_t(h.channels) * S, 0.0);
  h.node_centre.resize(n);
  for (size_t c = 0; c < h.clusters; ++c) h.node_centre[c] = h.cluster_centre[c];
  tbb::parallel_for(tbb::blocked_range<size_t>(h.clusters, n, 512),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i)
                        h.node_centre[i] = node_geometry(charts, h.key[i]).centre;
                    });
  pull_slots(h, h.emission, h.slot_emission);
}

void slot_directional(const Hierarchy& h, const std::vector<double>& slot_values, uint32_t cluster,
                      const Vec3& w, double* out) {
  const ClusterTree& t = *h.cluster_tree;
  const size_t S = t.slot_area.size();
  double sum[3] = {0.0, 0.0, 0.0}, weight = 0.0;
  for (uint32_t j = t.slot_first[cluster]; j < t.slot_first[cluster + 1]; ++j) {
    const double b = t.slot_projected_area(cluster, j, w);
    weight += b;
    for (int c = 0; c < h.channels; ++c) sum[c] += b * slot_values[size_t(c) * S + j];
  }
  if (!(weight > 0.0)) {
    // No slot faces w (the link's factor is 0 then): the area average.
    for (uint32_t j = t.slot_first[cluster]; j < t.slot_first[cluster + 1]; ++j) {
      weight += t.slot_area[j];
      for (int c = 0; c < h.channels; ++c)
        sum[c] += t.slot_area[j] * slot_values[size_t(c) * S + j];
    }
  }
  for (int c = 0; c < h.channels; ++c) out[c] = weight > 0.0 ? sum[c] / weight : 0.0;
}

double slot_share(const Hierarchy& h, uint32_t cluster, uint32_t slot, const Vec3& u) {
  const ClusterTree& t = *h.cluster_tree;
  const double projected = t.projected_area(cluster, u);
  if (!(projected > 0.0)) return 1.0;
  const double area = t.slot_area[slot];
  if (!(area > 0.0)) return 0.0;
  return t.slot_projected_area(cluster, slot, u) / area * (t.clusters[cluster].area / projected);
}

double jacobi_pass(Hierarchy& h) {
  if (h.slots) pull_slots(h, h.sent(), h.slot_sent);
  gather_range(h, 0, h.size());
  std::vector<double> next(h.B.size());
  const size_t charts = h.chart_first.size() - 1;
  std::vector<double> change(charts, 0.0);
  const std::vector<double> down = clusters_down(h);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, charts, 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t c = r.begin(); c < r.end(); ++c)
                        change[c] = push_pull(h, h.chart_first[c], chart_down(h, down, c), next);
                    });
  pull_clusters(h, next);
  h.B.swap(next);
  refresh_sent(h, 0, h.size());
  return charts ? *std::max_element(change.begin(), change.end()) : 0.0;
}

double gauss_seidel_pass(Hierarchy& h) {
  const size_t charts = h.chart_first.size() - 1;
  double change = 0.0;
  std::vector<double> next = h.B;
  if (h.slots) pull_slots(h, h.sent(), h.slot_sent);
  // The clusters gather first, from the B of the previous pass (one block of the sweep).
  if (h.clusters > 0) gather_range(h, 0, h.clusters);
  const std::vector<double> down = clusters_down(h);
  for (size_t c = 0; c < charts; ++c) {
    gather_range(h, h.chart_first[c], h.chart_first[c + 1]);
    change = std::max(change, push_pull(h, h.chart_first[c], chart_down(h, down, c), next));
    // Publish this chart's new values before the next chart gathers.
    for (int ch = 0; ch < h.channels; ++ch) {
      const size_t base = size_t(ch) * h.size();
      std::copy(next.begin() + long(base + h.chart_first[c]),
                next.begin() + long(base + h.chart_first[c + 1]),
                h.B.begin() + long(base + h.chart_first[c]));
    }
    refresh_sent(h, h.chart_first[c], h.chart_first[c + 1]);
  }
  if (h.clusters > 0) {
    pull_clusters(h, next);
    for (int ch = 0; ch < h.channels; ++ch) {
      const size_t base = size_t(ch) * h.size();
      std::copy(next.begin() + long(base), next.begin() + long(base + h.clusters),
                h.B.begin() + long(base));
    }
    refresh_sent(h, 0, h.clusters);
  }
  return change;
}

namespace {

struct Box {
  Vec2 lo{1e300}, hi{-1e300};
  void add(const Vec2& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  bool overlaps(const Box& o) const {
    return lo.x < o.hi.x && o.lo.x < hi.x && lo.y < o.hi.y && o.lo.y < hi.y;
  }
};

void accumulate(const Hierarchy& h, const Chart& chart, size_t i, const NodeGeometry& g,
                const ElementChart& e, const Box& box, double* sum, double& area) {
  Box nb;
  for (int k = 0; k < g.corners; ++k) nb.add(g.uv[k]);
  if (!nb.overlaps(box)) return;
  if (h.is_leaf(i)) {
    const double a = overlap_area(chart, e.uv, e.corners, g.uv, g.corners);
    if (a <= 0) return;
    area += a;
    for (int c = 0; c < h.channels; ++c) sum[c] += a * h.b(c, i);
    return;
  }
  for (int d = 0; d < 4; ++d)
    if (h.child[i][size_t(d)] >= 0)
      accumulate(h, chart, size_t(h.child[i][size_t(d)]), g.child(chart, d), e, box, sum, area);
}

}  // namespace

void project(const Hierarchy& h, const std::vector<Chart>& charts,
             const std::vector<ElementChart>& elements, Radiosity& out) {
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, elements.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t e = r.begin(); e < r.end(); ++e) {
          const ElementChart& ec = elements[e];
          double sum[3] = {0.0, 0.0, 0.0}, area = 0.0;
          if (ec.whole) {
            // An unsplit n-gon: the area average of its fan charts' roots.
            const uint32_t polygon = charts[ec.chart].polygon;
            for (uint32_t c = ec.chart; c < charts.size() && charts[c].polygon == polygon; ++c) {
              const size_t root = h.chart_first[c];
              area += h.area[root];
              for (int ch = 0; ch < h.channels; ++ch) sum[ch] += h.area[root] * h.b(ch, root);
            }
          } else {
            Box box;
            for (int k = 0; k < ec.corners; ++k) box.add(ec.uv[k]);
            const Chart& chart = charts[ec.chart];
            accumulate(h, chart, h.chart_first[ec.chart], root_geometry(chart), ec, box, sum, area);
          }
          for (int ch = 0; ch < h.channels; ++ch) out.at(ch, e) = area > 0 ? sum[ch] / area : 0.0;
        }
      });
}

}  // namespace radlab::hier
