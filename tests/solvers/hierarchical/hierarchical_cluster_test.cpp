// Tests of clustered hierarchical radiosity (clustering=isotropic; solvers/hierarchical/
// hierarchical_clusters.h): the cluster tree (Embree's rtcBuildBVH) groups every chart once,
// refinement starts from one link and covers every pair of polygons once (the furnace, and the
// unclustered run's links where no cluster link survives), energy is conserved with cluster links
// in the operator, the solution converges to the certified reference like the unclustered one,
// the same bits on any number of threads, and bad input names the key.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <map>
#include <numbers>

#include "core/error.h"
#include "core/random.h"
#include "formfactor/methods/raycast.h"
#include "metrics/error_metrics.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/mesh.h"
#include "scene/validate.h"
#include "solvers/hierarchical/hierarchical_clusters.h"
#include "solvers/hierarchical/hierarchical_hierarchy.h"
#include "solvers/hierarchical/hierarchical_refine.h"
#include "solvers/hierarchical/hierarchical_rows.h"
#include "solvers/hierarchical/hierarchical_visibility.h"
#include "solvers/registry.h"
#include "tests/hierarchical_support.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using namespace hier;

std::unique_ptr<Solver> make(const std::vector<std::string>& params) {
  ParamBag bag = ParamBag::from_assignments(params, "solver 'hierarchical'");
  return make_solver("hierarchical", bag);
}

void run_to_end(Solver& solver, int max_steps = 400) {
  for (int k = 0; k < max_steps; ++k)
    if (solver.step().finished) return;
  FAIL() << "hierarchical did not reach its fixed point in " << max_steps << " steps";
}

std::map<std::string, double> statistics_of(const Solver& solver) {
  std::map<std::string, double> st;
  for (const auto& [k, v] : solver.statistics()) st[k] = v;
  return st;
}

TEST(HierarchicalClusters, TheTreeGroupsEveryChartOnceParentsFirst) {
  Scene scene = make_builtin_scene("floors:k=2,patch=2");
  validate_scene(scene);
  const std::vector<Chart> charts = make_charts(scene);
  const ClusterTree t = build_clusters(charts);
  const size_t n = charts.size();
  ASSERT_EQ(t.size(), n - 1);  // a binary tree with one chart per leaf
  std::vector<int> seen(n, 0);
  for (uint32_t c : t.order) ++seen[c];
  for (size_t c = 0; c < n; ++c) EXPECT_EQ(seen[c], 1) << "chart " << c;
  double total = 0.0;
  for (const Chart& c : charts) total += c.area;
  EXPECT_NEAR(t.clusters[0].area, total, 1e-12 * total);
  EXPECT_EQ(t.clusters[0].count, n);
  for (size_t i = 0; i < t.size(); ++i) {
    const Cluster& c = t.clusters[i];
    if (i > 0) {
      EXPECT_LT(c.parent, int32_t(i));  // preorder: parents first
    }
    uint32_t count = 0;
    double area = 0.0;
    uint32_t at = c.first;
    for (int k = 0; k < 2; ++k) {
      if (c.child[k] >= 0) {
        const Cluster& d = t.clusters[size_t(c.child[k])];
        EXPECT_EQ(d.parent, int32_t(i));
        EXPECT_EQ(d.first, at);  // the children's ranges tile the parent's, in order
        at += d.count;
        count += d.count;
        area += d.area;
      } else {
        EXPECT_EQ(t.order[at], uint32_t(~c.child[k]));
        EXPECT_EQ(t.chart_parent[size_t(~c.child[k])], int32_t(i));
        ++at;
        ++count;
        area += charts[size_t(~c.child[k])].area;
      }
    }
    EXPECT_EQ(count, c.count);
    EXPECT_NEAR(area, c.area, 1e-12 * std::max(1.0, area));
    // The sphere holds the box, the box every corner of its charts.
    for (uint32_t k = c.first; k < c.first + c.count; ++k) {
      const Chart& chart = charts[t.order[k]];
      for (int j = 0; j < chart.corners; ++j) {
        EXPECT_LE(glm::length(chart.x[j] - c.centre), c.radius * (1 + 1e-12));
        for (int a = 0; a < 3; ++a) {
          EXPECT_GE(chart.x[j][a], c.lo[a]);
          EXPECT_LE(chart.x[j][a], c.hi[a]);
        }
      }
    }
  }
  // Embree's build makes the same tree again.
  const ClusterTree again = build_clusters(charts);
  EXPECT_EQ(again.order, t.order);
}

TEST(HierarchicalClusters, OneInitialLinkAndRefinementTestsGrowSlowerThanPairs) {
  // Unclustered refinement starts from the n(n-1)/2 pairs of polygons, each a refinement test;
  // clustered from one link, the root cluster with itself. Doubling the building (4 -> 8
  // storeys, patch 2 m: 672 -> 1,344 polygons, feps 0.04) quadruples the pairs: the unclustered
  // tests grow by 2.93 (the pairs' n^2 showing: more than 2.5 asserted), the clustered by 1.86
  // (below 2.2, what n log n gives for this doubling: distant storeys meet as clusters, not as
  // pairs of polygons).
  double tests[2][2];
  for (int k : {0, 1}) {
    Scene scene = make_builtin_scene(k == 0 ? "floors:k=4,patch=2" : "floors:k=8,patch=2");
    validate_scene(scene);
    const Mesh mesh = build_mesh(scene, {1, 0.0});
    const RaycastFormFactors rows(scene, mesh, RaycastOptions{});  // never asked: no flat rows
    const System system(scene, mesh, rows);
    const double n = double(scene.polygons.size());
    for (int clustered : {0, 1}) {
      auto solver = make({"feps=0.04", clustered ? "clustering=isotropic" : "clustering=none"});
      solver->init(system);
      solver->step();  // the refinement pass
      auto st = statistics_of(*solver);
      EXPECT_EQ(st["initial_links"], clustered ? 1.0 : n * (n - 1) / 2);
      if (clustered) {
        EXPECT_EQ(st["clusters"], n - 1);
      } else {
        EXPECT_GE(st["refinement_tests"], n * (n - 1) / 2);
      }
      tests[k][clustered] = st["refinement_tests"];
      std::printf("n %.0f clustered %d: %.0f tests, %.0f links\n", n, clustered,
                  st["refinement_tests"], st["links"]);
    }
  }
  EXPECT_GT(tests[1][0] / tests[0][0], 2.5);
  EXPECT_LT(tests[1][1] / tests[0][1], 2.2);
}

TEST(HierarchicalClusters, FurnaceGivesEOverOneMinusRho) {
  // As unclustered (hierarchical_test.cpp): every pair of the box's faces is reached once
  // through the clusters, so every leaf's row is 1 to rounding and B = 1/0.3 to 1e-12. A pair
  // reached twice or never moves B by percents. Isotropic and oriented clusters alike.
  auto s = testing::hierarchical_setup("furnace:rho=0.7", 4);
  for (const char* clustering : {"clustering=isotropic", "clustering=oriented"})
    for (const char* feps : {"feps=0.01", "feps=0.0025"}) {
      auto solver = make({feps, clustering});
      solver->init(*s->system);
      run_to_end(*solver);
      double worst = 0.0;
      for (size_t i = 0; i < s->mesh.size(); ++i)
        worst = std::max(worst, std::abs(solver->solution().at(0, i) * 0.3 - 1.0));
      EXPECT_LT(worst, 1e-12) << clustering << " " << feps;
    }
}

TEST(HierarchicalClusters, WithoutClusterLinksTheLinksAreTheUnclusteredOnes) {
  // On the Cornell box at feps 0.01 every cluster pair is opened down to pairs of polygons,
  // which are refined in refine_roots' order with the same rays: the same links, so the same
  // solution up to the order of the sums (1e-12 relative).
  auto s = testing::hierarchical_setup("cornell", 2);
  auto none = make({"feps=0.01"});
  auto iso = make({"feps=0.01", "clustering=isotropic"});
  for (Solver* solver : {none.get(), iso.get()}) {
    solver->init(*s->system);
    run_to_end(*solver);
  }
  auto a = statistics_of(*none), b = statistics_of(*iso);
  EXPECT_EQ(b["links_with_a_cluster"], 0.0);
  EXPECT_EQ(a["links"], b["links"]);
  EXPECT_EQ(a["leaves"], b["leaves"]);
  EXPECT_EQ(a["links_partial"], b["links_partial"]);
  double top = 0.0;
  for (double v : none->solution().raw()) top = std::max(top, std::abs(v));
  for (size_t k = 0; k < none->solution().raw().size(); ++k)
    EXPECT_NEAR(none->solution().raw()[k], iso->solution().raw()[k], 1e-12 * top) << k;
}

TEST(HierarchicalClusters, ConvergesToTheCertifiedReferenceLikeUnclustered) {
  // The same tolerance class as unclustered at the same feps: the clustered rms_rel within 1.5x
  // of the unclustered (and below 1%), on the Cornell box and on an occluded building (two
  // storeys, desks, slabs, the atrium), where cluster links do remain; isotropic and oriented.
  const char* modes[3] = {"clustering=none", "clustering=isotropic", "clustering=oriented"};
  for (const auto& [spec, subdiv] : {std::pair{"cornell", 8}, std::pair{"floors:k=2,patch=2", 2}}) {
    auto s = testing::hierarchical_setup(spec, subdiv);
    double rms[3];
    double cluster_links[3] = {0.0, 0.0, 0.0};
    for (int mode : {0, 1, 2}) {
      auto solver = make({"feps=0.01", modes[mode]});
      solver->init(*s->system);
      run_to_end(*solver, 2000);
      rms[mode] =
          compare(solver->solution(), s->reference.B, s->system->area(), kMeanOfChannels).rms_rel;
      if (mode > 0) cluster_links[mode] = statistics_of(*solver)["links_with_a_cluster"];
    }
    std::printf(
        "%s: rms_rel none %.4g, isotropic %.4g (%.0f cluster links), oriented %.4g "
        "(%.0f)\n",
        spec, rms[0], rms[1], cluster_links[1], rms[2], cluster_links[2]);
    for (int mode : {1, 2}) {
      EXPECT_LT(rms[mode], 1.5 * rms[0]) << spec << " " << modes[mode];
      EXPECT_LT(rms[mode], 0.01) << spec << " " << modes[mode];
    }
  }
}

TEST(HierarchicalClusters, OrientedClustersAreNoWorseThanUnclustered) {
  // The building's reflected light (rms_rel_reflected, the room's light without the lamps)
  // at feps 0.04, where cluster links carry much of it, against the certified reference: issue
  // 33's target is the clustered error no worse than the unclustered at the same feps, asserted
  // as it stands (measured: floors k=2 0.0280 against 0.0291, k=4 0.0224 against 0.0229).
  // Isotropic clusters fail it (k=2 0.0381: the A/4 bound and Laplace's rule for blocked
  // pairs), and so did oriented ones while a cluster's light was pushed to its faces alike and
  // pulled as their area average, and lamps could sit inside linked clusters (k=2 0.0295, k=4
  // 0.0273; either fix alone: k=2 0.0309 and 0.0318).
  for (const auto& [spec, subdiv] :
       {std::pair{"floors:k=2,patch=2", 2}, std::pair{"floors:k=4,patch=2", 1}}) {
    auto s = testing::hierarchical_setup(spec, subdiv);
    double rms[2];
    for (int oriented : {0, 1}) {
      auto solver = make({"feps=0.04", oriented ? "clustering=oriented" : "clustering=none"});
      solver->init(*s->system);
      run_to_end(*solver, 2000);
      rms[oriented] = compare_reflected(solver->solution(), s->reference.B, s->system->emission(),
                                        s->system->area(), kMeanOfChannels)
                          .rms_rel;
    }
    std::printf("%s feps 0.04: rms_rel_reflected none %.4g, oriented %.4g\n", spec, rms[0], rms[1]);
    EXPECT_LE(rms[1], rms[0]) << spec;
  }
}

// A square chart of side `side` centred at `centre` facing `normal` (an axis).
Chart square(const Vec3& centre, const Vec3& normal, double side) {
  const Vec3 a = std::abs(normal.z) > 0.5 ? Vec3(1, 0, 0) : Vec3(0, 0, 1);
  const Vec3 b = glm::cross(normal, a);
  Chart c;
  c.corners = 4;
  const double h = 0.5 * side;
  c.x[0] = centre - h * a - h * b;
  c.x[1] = centre + h * a - h * b;
  c.x[2] = centre + h * a + h * b;
  c.x[3] = centre - h * a + h * b;
  c.normal = normal;
  c.area = side * side;
  return c;
}

// The exact projected area of charts in direction w: sum A max(n . w, 0).
double exact_projected(const std::vector<Chart>& charts, const Vec3& w) {
  double p = 0.0;
  for (const Chart& c : charts) p += c.area * std::max(0.0, glm::dot(c.normal, w));
  return p;
}

TEST(HierarchicalClusters, OrientedProjectedAreaIsThePolygonsOwn) {
  // Two facing squares (a floor and the ceiling above it, 2 m^2 and 3 m^2): seen from above the
  // cluster shows the floor only (2 m^2), from below the ceiling (3 m^2), edge-on nothing; the
  // isotropic A/4 is 1.25 m^2 from everywhere. The oriented value must be the exact sum, and
  // the kernel from a point x above must be P cos / (π r²) with that P.
  const std::vector<Chart> charts = {square({0, 0, 0}, {0, 0, 1}, std::sqrt(2.0)),
                                     square({0, 0, 2}, {0, 0, -1}, std::sqrt(3.0))};
  const ClusterTree oriented = build_clusters(charts, true);
  const ClusterTree isotropic = build_clusters(charts, false);
  ASSERT_EQ(oriented.size(), 1u);
  for (const Vec3& w : {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), glm::normalize(Vec3(1, 1, 1)),
                        glm::normalize(Vec3(0.3, -2, -1))}) {
    EXPECT_NEAR(oriented.projected_area(0, w), exact_projected(charts, w), 1e-14) << w.z;
    EXPECT_NEAR(isotropic.projected_area(0, w), 1.25, 1e-14);
    // The bound over a cone holds every direction in it and is the value itself at zero spread.
    EXPECT_NEAR(oriented.projected_area_bound(0, w, 0.0), exact_projected(charts, w), 1e-12);
  }
  const Vec3 x(0.5, 0.2, 7.0), up(0, 0, -1);  // a point above, facing down
  const Vec3 d = oriented.clusters[0].centre - x;
  const double r = glm::length(d);
  EXPECT_NEAR(oriented.point_factor(0, x, up),
              exact_projected(charts, -d / r) * glm::dot(up, d / r) / (std::numbers::pi * r * r),
              1e-15);
}

TEST(HierarchicalClusters, OrientedBoundHoldsAndPastTheListTheRestIsIsotropic) {
  // 40 squares with 40 distinct normals (past kOrientedNormals = 16): the root keeps 16 normals
  // exactly and counts the rest's area as an isotropic remainder (A_rest / 4 in the estimate, the
  // whole A_rest in the bound). The bound over a cone must hold the exact projected area of every
  // direction in it.
  std::vector<Chart> charts;
  double total = 0.0;
  for (int k = 0; k < 40; ++k) {
    const double t = 0.7 * k, z = -0.95 + 1.9 * k / 39.0;
    const Vec3 n = glm::normalize(
        Vec3(std::cos(t) * std::sqrt(1 - z * z), std::sin(t) * std::sqrt(1 - z * z), z));
    Chart c = square(3.0 * n, {0, 0, 1}, 0.5 + 0.01 * k);
    c.normal = n;  // only the normal and area matter to the projected area
    charts.push_back(c);
    total += c.area;
  }
  const ClusterTree t = build_clusters(charts, true);
  const uint32_t kept = t.normal_first[1] - t.normal_first[0];
  EXPECT_EQ(kept, kOrientedNormals);
  double kept_area = 0.0;
  for (uint32_t k = t.normal_first[0]; k < t.normal_first[1]; ++k) kept_area += t.normal_area[k];
  EXPECT_NEAR(kept_area + t.rest_area[0], total, 1e-12 * total);
  EXPECT_GT(t.rest_area[0], 0.0);
  Pcg32 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const double z = 2 * rng.next_double() - 1, phi = 2 * std::numbers::pi * rng.next_double();
    const Vec3 w(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
    const double spread = 0.5 * rng.next_double();
    const double bound = t.projected_area_bound(0, w, spread);
    // A direction within the cone: w tilted by up to `spread`.
    const Vec3 side =
        glm::normalize(glm::cross(w, std::abs(w.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0)));
    for (double tilt : {0.0, 0.5 * spread, spread}) {
      const Vec3 v = std::cos(tilt) * w + std::sin(tilt) * side;
      EXPECT_GE(bound, exact_projected(charts, v) * (1 - 1e-12)) << trial;
    }
  }
}

// A slab (two back-to-back unit squares 2 cm apart, facing +z and -z) between two unit squares
// 10 m above and below it facing it, linked as the oriented refinement links them: the slab's
// cluster to each square's root, the factors of hierarchical_refine.h (the square gathers the
// cluster's point kernel at its centre, the cluster the reciprocal). No row normalisation, so a
// Jacobi pass shows the push and the pull themselves.
struct Slab {
  std::vector<Chart> charts;
  ClusterTree tree;
  uint32_t slab = 0;        // the cluster holding the two faces
  double gather_factor[2];  // the cluster's factor from the square above [0] and below [1]
  double analytic[2];       // a face's form factor to the square it faces
  Hierarchy hierarchy(const std::vector<double>& emission, const std::vector<double>& rho) const {
    std::vector<Rgb> e, r;
    for (size_t c = 0; c < charts.size(); ++c) {
      e.emplace_back(emission[c]);
      r.emplace_back(rho[c]);
    }
    std::vector<LinkRecord> links;
    for (uint32_t k : {2u, 3u}) {
      LinkRecord l;
      l.p = NodeKey::cluster(slab);
      l.q = {k, 0, 0};
      const Chart& square = charts[k];
      l.fqp = tree.point_factor(slab, root_geometry(square).centre, square.normal);
      l.fpq = l.fqp * square.area / tree.clusters[slab].area;
      links.push_back(l);
    }
    return build_hierarchy(charts, links, nullptr, e, r, 1, &tree);
  }
};

Slab make_slab() {
  Slab s;
  s.charts = {square({0, 0, 0.01}, {0, 0, 1}, 1.0), square({0, 0, -0.01}, {0, 0, -1}, 1.0),
              square({0, 0, 10}, {0, 0, -1}, 1.0), square({0, 0, -10}, {0, 0, 1}, 1.0)};
  s.tree = build_clusters(s.charts, true);
  bool found = false;
  for (uint32_t c = 0; c < s.tree.size(); ++c) {
    const Cluster& cl = s.tree.clusters[c];
    if (cl.count == 2 && cl.child[0] < 0 && cl.child[1] < 0 &&
        (~cl.child[0]) + (~cl.child[1]) == 1) {
      s.slab = c;
      found = true;
    }
  }
  EXPECT_TRUE(found) << "the BVH put the slab's two faces in one cluster";
  for (int k : {0, 1}) {
    const Chart& square = s.charts[size_t(2 + k)];
    s.gather_factor[k] = s.tree.point_factor(s.slab, root_geometry(square).centre, square.normal) *
                         square.area / s.tree.clusters[s.slab].area;
    // Two coaxial unit squares 9.99 m apart: F = A cos cos / (π r²) to O((side / r)²), 1%.
    s.analytic[k] = 1.0 / (std::numbers::pi * 9.99 * 9.99);
  }
  return s;
}

TEST(HierarchicalClusters, OrientedPushGivesEachFaceOnlyTheLightItFaces) {
  // The squares above and below send B = 1 and 0.25 (emitters that reflect nothing); the slab's
  // faces reflect everything (rho = 1), so after one Jacobi pass a face's B is what it received.
  // The face turned up sees only the square above: its irradiance is that square's form factor
  // times 1 (the analytic value, 1%), and the face turned down gets 0.25 times its own. The
  // uniform push gave both faces the cluster's average, 0.5 (1 + 0.25) F: the lower face 2.5x
  // too much, light leaking through the slab. Both ways of receiving are checked: the slots'
  // push (rows=links), which also gives the faces exactly the power the cluster gathered, and
  // the leaves' own rule with row normalisation (the default rows=leaf).
  const Slab s = make_slab();
  for (bool rows : {false, true}) {
    Hierarchy h = s.hierarchy({0, 0, 1.0, 0.25}, {1.0, 1.0, 0.0, 0.0});
    enable_orientation_slots(h, s.charts);
    ASSERT_TRUE(h.slots);
    if (rows) {
      normalise_rows(h, s.charts);
      ASSERT_TRUE(h.leaf_rule());
    }
    jacobi_pass(h);
    const double up = h.b(0, h.chart_first[0]), down = h.b(0, h.chart_first[1]);
    EXPECT_NEAR(up, 1.0 * s.analytic[0], 0.01 * s.analytic[0]) << "rows " << rows;
    EXPECT_NEAR(down, 0.25 * s.analytic[1], 0.01 * 0.25 * s.analytic[1]) << "rows " << rows;
    if (rows) continue;
    // Power: what the cluster gathered (area times its factors times B) is what the faces got.
    const double gathered =
        s.tree.clusters[s.slab].area * (s.gather_factor[0] * 1.0 + s.gather_factor[1] * 0.25);
    EXPECT_NEAR(up * s.charts[0].area + down * s.charts[1].area, gathered, 1e-12 * gathered);
  }
}

TEST(HierarchicalClusters, OrientedRefinementLinksNoClusterHoldingALamp) {
  // A lamp inside a linked cluster would send its emission spread over the cluster's faces from
  // the cluster's centre, moving the direct light (refinement on F alone does not see it); such
  // clusters are opened until the lamp is a surface of its own. The building's first pass, from
  // the root cluster's frontier: no link has an emitting cluster end, while links with cluster
  // ends remain. Without the marks the same refinement links emitting clusters (checked below,
  // so the rule is what keeps them out).
  Scene scene = make_builtin_scene("floors:k=2,patch=2");
  validate_scene(scene);
  const std::vector<Chart> charts = make_charts(scene);
  std::vector<uint8_t> emits(charts.size(), 0);
  for (size_t c = 0; c < charts.size(); ++c)
    emits[c] = scene.materials[size_t(scene.polygons[charts[c].polygon].material)].emits();
  const NodeVisibility visibility(scene);
  RefineCriterion criterion;
  criterion.feps = 0.04;
  double total_area = 0.0;
  for (const Chart& c : charts) total_area += c.area;
  criterion.min_area = 1e-4 * total_area;  // the solver's default aeps
  for (bool marked : {true, false}) {
    ClusterTree tree = build_clusters(charts, true);
    if (marked) mark_emitters(tree, emits);
    // Which clusters hold a lamp, from the charts' ranges (independently of mark_emitters).
    std::vector<uint8_t> lamp(tree.size(), 0);
    for (size_t c = 0; c < tree.size(); ++c)
      for (uint32_t k = tree.clusters[c].first; k < tree.clusters[c].first + tree.clusters[c].count;
           ++k)
        lamp[c] |= emits[tree.order[k]];
    const Refiner refiner(charts, visibility, criterion, &tree);
    std::vector<LinkRecord> links;
    RefineStats stats;
    for (const auto& [a, b] : Refiner::cluster_frontier(tree))
      refiner.refine_keys(a, b, links, stats);
    size_t with_cluster = 0, with_lamp = 0;
    for (const LinkRecord& l : links)
      for (const NodeKey& k : {l.p, l.q})
        if (k.is_cluster()) {
          ++with_cluster;
          with_lamp += lamp[k.chart];
        }
    std::printf("marked %d: %zu links, %zu cluster ends, %zu holding a lamp\n", int(marked),
                links.size(), with_cluster, with_lamp);
    EXPECT_GT(with_cluster, 0u);
    if (marked)
      EXPECT_EQ(with_lamp, 0u);
    else
      EXPECT_GT(with_lamp, 0u);
  }
}

TEST(HierarchicalClusters, OrientedPullSendsTheLightOfTheFacesTurnedToTheReceiver) {
  // The slab's upper face emits B = 1, its lower face nothing; the squares reflect everything.
  // The square above sees only the upper face: it receives 1 times its form factor to it (the
  // analytic value, 1%); the square below sees only the dark face and receives nothing. The
  // area-average pull sent both 0.5 F.
  const Slab s = make_slab();
  Hierarchy h = s.hierarchy({1.0, 0.0, 0.0, 0.0}, {0.0, 0.0, 1.0, 1.0});
  enable_orientation_slots(h, s.charts);
  jacobi_pass(h);
  EXPECT_NEAR(h.b(0, h.chart_first[2]), s.analytic[0], 0.01 * s.analytic[0]);
  EXPECT_EQ(h.b(0, h.chart_first[3]), 0.0);
}

TEST(HierarchicalClusters, SameBitsOnOneThreadAndOnMany) {
  auto s = testing::hierarchical_setup("floors:k=2,patch=2", 1);
  Radiosity one, many;
  for (int threads : {1, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    auto solver = make({"feps=0.01", "clustering=isotropic", "levels=2", "gathers=2"});
    solver->init(*s->system);
    run_to_end(*solver);
    (threads == 1 ? one : many) = solver->solution();
  }
  ASSERT_EQ(one.raw().size(), many.raw().size());
  for (size_t k = 0; k < one.raw().size(); ++k) ASSERT_EQ(one.raw()[k], many.raw()[k]) << k;
}

TEST(HierarchicalClusters, UnknownClusteringNamesTheKey) {
  for (const char* bad : {"clustering=anisotropic", "clustering=", "clustering=yes"})
    testing::expect_error<UsageError>([&] { make({bad}); }, {"clustering"});
}

}  // namespace
}  // namespace radlab
