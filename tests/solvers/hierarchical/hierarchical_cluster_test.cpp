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

#include "core/error.h"
#include "formfactor/methods/raycast.h"
#include "metrics/error_metrics.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/mesh.h"
#include "scene/validate.h"
#include "solvers/hierarchical/hierarchical_clusters.h"
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
  // reached twice or never moves B by percents.
  auto s = testing::hierarchical_setup("furnace:rho=0.7", 4);
  for (const char* feps : {"feps=0.01", "feps=0.0025"}) {
    auto solver = make({feps, "clustering=isotropic"});
    solver->init(*s->system);
    run_to_end(*solver);
    double worst = 0.0;
    for (size_t i = 0; i < s->mesh.size(); ++i)
      worst = std::max(worst, std::abs(solver->solution().at(0, i) * 0.3 - 1.0));
    EXPECT_LT(worst, 1e-12) << feps;
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
  // storeys, desks, slabs, the atrium), where cluster links do remain.
  for (const auto& [spec, subdiv] : {std::pair{"cornell", 8}, std::pair{"floors:k=2,patch=2", 2}}) {
    auto s = testing::hierarchical_setup(spec, subdiv);
    double rms[2];
    double cluster_links = 0.0;
    for (int clustered : {0, 1}) {
      auto solver = make({"feps=0.01", clustered ? "clustering=isotropic" : "clustering=none"});
      solver->init(*s->system);
      run_to_end(*solver, 2000);
      rms[clustered] =
          compare(solver->solution(), s->reference.B, s->system->area(), kMeanOfChannels).rms_rel;
      if (clustered) cluster_links = statistics_of(*solver)["links_with_a_cluster"];
    }
    std::printf("%s: rms_rel none %.4g, isotropic %.4g (%.0f cluster links)\n", spec, rms[0],
                rms[1], cluster_links);
    EXPECT_LT(rms[1], 1.5 * rms[0]) << spec;
    EXPECT_LT(rms[1], 0.01) << spec;
  }
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
  for (const char* bad : {"clustering=oriented", "clustering=", "clustering=yes"})
    testing::expect_error<UsageError>([&] { make({bad}); }, {"clustering"});
}

}  // namespace
}  // namespace radlab
