// hierarchical — hierarchical radiosity (Hanrahan, Salzman & Aupperle 1991).
//
// Method: every input polygon is the root of a quadtree (hierarchical_tree.h). Refine(p, q, feps,
//   aeps) over every pair of roots links pairs of nodes whose estimated form factors are below
//   feps, splitting the node seen larger otherwise (hierarchical_refine.h); visibility by a plane
//   test and 16 jittered rays through Embree, with the paper's triage and coherence
//   (hierarchical_visibility.h). The links (O(n), not n^2) are then iterated: Gather over links
//   and PushPull through the quadtrees, as Jacobi passes or, as an option, Gauss–Seidel (chart
//   after chart, newest values). Options from §5.2: multigridding (a schedule of `levels`
//   thresholds feps * 4^(levels-1) ... feps, with `gathers` passes at each but the last, links
//   that fail the finer threshold replaced by the links refinement makes below them) and BF
//   refinement (the oracle weighs F by rho_p B_q / mean B, the scene's area-weighted mean
//   radiosity, so refinement waits for light to arrive; needs levels >= 2, since the first pass
//   sees only E).
// Row normalisation (rows=leaf; hierarchical_rows.h): every leaf scales what it
//   gathers to its own 2 x 2 rule's row sum over the links on its path, clamped at 1, so no
//   leaf's row sums above 1 (the paper's link sums reach 1.5 and diverge at rho near 1).
// Measured on the run's mesh: the solution is the area average of the hierarchy's leaves over
//   each mesh element (exact clipping in parameter space), so rms and p-error compare with the
//   certified reference of the uniform system. The hierarchy is a different discretisation with
//   its own (estimated) form factors: its error against that reference has a floor that falls
//   with feps and aeps, never to zero.
// Parameters: feps (link threshold on the estimated form factor), aeps (smallest splittable
//   node, as a fraction of the scene's total area: scale-free, so one default serves the built-in
//   rooms and the RenderPark scenes), refine (f or bf), levels, gathers, order, rows (leaf or
//   links), seed (jitter); defaults: `radlab solvers` (HierarchicalOptions).
// Cost per step: one refinement pass (the first step, and the first of each multigrid level) or
//   one gather + push/pull pass over all links and nodes. Work charged: 2 element-pair form
//   factors per refinement test and per link made, 2 per link per gather pass (a link's two
//   factors, the unit of a flat row's n), 16 rays per visibility test.
// Clustering (clustering=isotropic|oriented; Smits, Arvo & Greenberg 1994, Sillion 1995): the
//   charts are
//   grouped by a binary bounding-volume hierarchy built with Embree's rtcBuildBVH (binned SAH;
//   hierarchical_clusters.h), and refinement starts from one link, the root cluster with itself,
//   instead of the n(n-1)/2 pairs of roots: its self link opens into the n - 1 pairs of sibling
//   children (hierarchical_refine.h), refined in parallel in preorder. Cluster ends use the
//   isotropic kernel (a point of projected area A/4) or the oriented one (the projected area of
//   its polygons, from a list of distinct normals) with an estimate bounded over the two
//   bounding spheres, clusters open before polygons, visibility between clusters by 16 segments
//   between points on their charts (Embree), and gathers push a cluster's light to all its charts
//   and pull its B as their area average (hierarchical_hierarchy.h); oriented clusters push and
//   pull per orientation instead (a face gets only the light of the sources it faces, a link
//   reads the faces turned to its receiver; rows=balanced keeps the area-average ones).
//   clustering=none (the default) makes exactly the unclustered links, the same bits as before
//   clustering existed.
// Left out: lazy linking, shooting, and error-driven (rather than F- or BF-driven) oracles.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <memory>
#include <string>

#include "core/error.h"
#include "core/log.h"
#include "core/text.h"
#include "solvers/hierarchical/hierarchical_hierarchy.h"
#include "solvers/hierarchical/hierarchical_rows.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

using namespace hier;

struct HierarchicalOptions {
  double feps = 0.01;
  double aeps = 1e-4;
  std::string refine = "f";
  long long levels = 1;
  long long gathers = 4;
  std::string order = "jacobi";
  std::string rows = "leaf";
  long long seed = 1;
  std::string clustering = "none";

  static HierarchicalOptions from(ParamBag& bag) {
    HierarchicalOptions o;
    o.feps = bag.get_double("feps", o.feps);
    o.aeps = bag.get_double("aeps", o.aeps);
    o.refine = bag.get_choice("refine", o.refine, {"f", "bf"});
    o.levels = bag.get_int("levels", o.levels);
    o.gathers = bag.get_int("gathers", o.gathers);
    o.order = bag.get_choice("order", o.order, {"jacobi", "gauss-seidel"});
    o.rows = bag.get_choice("rows", o.rows, {"leaf", "balanced", "links"});
    o.seed = bag.get_int("seed", o.seed);
    o.clustering = bag.get_choice("clustering", o.clustering, {"none", "isotropic", "oriented"});
    o.validate();
    return o;
  }
  void validate() const {
    if (!(feps > 0.0 && std::isfinite(feps)))
      throw UsageError("hierarchical: feps must be a finite number > 0, got " +
                       std::to_string(feps));
    if (!(aeps >= 0.0 && aeps < 1.0))
      throw UsageError(
          "hierarchical: aeps (a fraction of the scene's area) must lie in [0,1), got " +
          std::to_string(aeps));
    if (levels < 1 || levels > 12)
      throw UsageError("hierarchical: levels must lie in [1,12], got " + std::to_string(levels));
    if (refine == "bf" && levels < 2)
      throw UsageError(
          "hierarchical: refine=bf needs levels >= 2 (the first refinement sees only E)");
    if (gathers < 1)
      throw UsageError("hierarchical: gathers must be >= 1, got " + std::to_string(gathers));
    if (seed < 0) throw UsageError("hierarchical: seed must be >= 0, got " + std::to_string(seed));
  }
};

// The process's peak resident set so far (Linux VmHWM), in bytes; 0 where /proc is absent. The
// whole process's, not the solver's alone: the run's mesh and any matrix count too.
double peak_rss_bytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) * 1024.0;
  return 0.0;
}

struct PassRecord {
  double feps = 0.0, seconds = 0.0, peak_rss = 0.0;
  size_t nodes = 0, leaves = 0, links = 0, memory = 0;
  RefineStats stats;
  RowStats rows;
};

class HierarchicalSolver final : public Solver {
 public:
  explicit HierarchicalSolver(HierarchicalOptions options) : o_(options) {}

  void init(const System& system) override {
    system_ = &system;
    const Scene& scene = system.scene();
    charts_ = make_charts(scene);
    elements_ = element_charts(scene, system.mesh(), charts_);
    clusters_ = o_.clustering != "none" ? build_clusters(charts_, o_.clustering == "oriented")
                                        : ClusterTree{};
    if (o_.clustering == "oriented" && clusters_.size() > 0) {
      std::vector<uint8_t> emits(charts_.size(), 0);
      for (size_t c = 0; c < charts_.size(); ++c)
        emits[c] = scene.materials[size_t(scene.polygons[charts_[c].polygon].material)].emits();
      mark_emitters(clusters_, emits);
    }
    visibility_ = std::make_unique<NodeVisibility>(scene);
    channels_ = system.channels();
    chart_emission_.clear();
    chart_reflectance_.clear();
    double total_area = 0.0;
    for (const Chart& c : charts_) {
      const Material& m = scene.materials[size_t(scene.polygons[c.polygon].material)];
      chart_emission_.push_back(m.emission);
      chart_reflectance_.push_back(m.reflectance);
      total_area += c.area;
    }
    min_area_ = o_.aeps * total_area;
    links_.clear();
    counts_ = LinkCounts{};
    passes_.clear();
    gather_passes_ = 0;
    gather_seconds_ = 0.0;
    level_ = 0;
    gathers_at_level_ = 0;
    need_refine_ = true;
    tree_ = build_hierarchy(charts_, links_, nullptr, chart_emission_, chart_reflectance_,
                            channels_, &clusters_);
    solution_ = Radiosity(channels_, system.size());
    project(tree_, charts_, elements_, solution_);
  }

  StepInfo step() override {
    if (need_refine_) {
      refinement_pass();
      need_refine_ = false;
      gathers_at_level_ = 0;
      project(tree_, charts_, elements_, solution_);
      return {};
    }
    const auto t0 = std::chrono::steady_clock::now();
    const double change = o_.order == "jacobi" ? jacobi_pass(tree_) : gauss_seidel_pass(tree_);
    system_->charge_pair_evaluations(tree_.source.size());
    project(tree_, charts_, elements_, solution_);
    gather_seconds_ += seconds_since(t0);
    ++gather_passes_;
    ++gathers_at_level_;
    const bool last = level_ + 1 >= o_.levels;
    if (!last && gathers_at_level_ >= o_.gathers) {
      ++level_;
      need_refine_ = true;
      return {};
    }
    double top = 0.0;
    for (double b : tree_.B) top = std::max(top, std::abs(b));
    // The fixed point of the links: no leaf moved by more than 1e-14 of the largest value (a few
    // ulps of the sums). Further passes would change nothing measurable.
    StepInfo info;
    info.finished = last && change <= 1e-14 * top;
    return info;
  }

  const Radiosity& solution() const override { return solution_; }
  size_t solver_elements() const override { return tree_.leaves; }

  std::vector<std::pair<std::string, double>> statistics() const override {
    std::vector<std::pair<std::string, double>> s;
    RefineStats total;
    double refine_seconds = 0.0;
    for (const PassRecord& p : passes_) {
      total.add(p.stats);
      refine_seconds += p.seconds;
    }
    auto add = [&](const std::string& k, double v) { s.emplace_back(k, v); };
    add("input_polygons", double(system_->scene().polygons.size()));
    add("charts", double(charts_.size()));
    add("nodes", double(tree_.size()));
    add("leaves", double(tree_.leaves));
    add("max_depth", double(counts_.max_depth));
    add("links", double(links_.size()));
    if (o_.clustering != "none") {
      add("clusters", double(clusters_.size()));
      add("links_with_a_cluster", double(counts_.with_a_cluster));
    }
    // The pairs refinement starts from: every pair of roots, or the root cluster with itself.
    const double n = double(charts_.size());
    add("initial_links", o_.clustering != "none" && clusters_.size() > 0 ? 1.0 : n * (n - 1) / 2);
    add("links_visible", double(counts_.visible));
    add("links_partial", double(counts_.partial));
    add("links_cut_by_plane", double(counts_.cut));
    add("refinement_tests", double(total.refinement_tests));
    add("pairs_facing_away", double(total.facing_away));
    add("pairs_occluded", double(total.occluded));
    add("pairs_degenerate", double(total.degenerate));
    add("visibility_tests", double(total.visibility_tests));
    add("pairs_inherited_visible", double(total.inherited_visible));
    add("rays", double(total.rays));
    add("memory_bytes", double(tree_.memory_bytes() + links_.capacity() * sizeof(LinkRecord) +
                               clusters_.memory_bytes()));
    add("nonfinite_link_factors", double(counts_.nonfinite_factors));
    add("refinement_passes", double(passes_.size()));
    add("refinement_seconds", refine_seconds);
    add("gather_passes", double(gather_passes_));
    add("gather_seconds", gather_seconds_);
    for (size_t k = 0; k < passes_.size(); ++k) {
      const PassRecord& p = passes_[k];
      const std::string pre = "pass" + std::to_string(k + 1) + ".";
      add(pre + "feps", p.feps);
      add(pre + "seconds", p.seconds);
      add(pre + "nodes", double(p.nodes));
      add(pre + "leaves", double(p.leaves));
      add(pre + "links", double(p.links));
      add(pre + "refinement_tests", double(p.stats.refinement_tests));
      add(pre + "visibility_tests", double(p.stats.visibility_tests));
      add(pre + "rays", double(p.stats.rays));
      add(pre + "memory_bytes", double(p.memory));
      add(pre + "peak_rss_bytes", p.peak_rss);
      if (o_.rows != "links") {
        add(pre + "row_link_sum_max", p.rows.max_link_sum);
        add(pre + "row_link_sum_min", p.rows.min_link_sum);
        add(pre + "row_leaves_above_one", double(p.rows.leaves_above_one));
        add(pre + "row_scale_change_max", p.rows.max_change);
        add(pre + "row_sum_max", p.rows.max_row);
        add(pre + "row_evaluations", double(p.rows.evaluations));
        add(pre + "row_nonfinite_values", double(p.rows.nonfinite));
        add(pre + "column_sum_min", p.rows.min_column);
        add(pre + "column_sum_max", p.rows.max_column);
        add(pre + "column_sum_mean_deviation", p.rows.mean_column_deviation);
        if (o_.rows == "balanced") {
          add(pre + "column_balance_rounds", double(p.rows.balance_rounds));
          add(pre + "column_balance_residual", p.rows.balance_residual);
        }
      }
    }
    return s;
  }

 private:
  static double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  // Concatenates the per-task link lists into `out` (reserved to the exact total, so no
  // reallocation and no shrink copy), freeing each list once copied: the pass's peak holds the
  // links about once, not twice (hosp.mgf: 8.3 M links of 64 bytes).
  static void append_in_order(std::vector<std::vector<LinkRecord>>& parts,
                              std::vector<LinkRecord>& out) {
    size_t total = 0;
    for (const auto& p : parts) total += p.size();
    out.reserve(total);
    for (auto& p : parts) {
      out.insert(out.end(), p.begin(), p.end());
      std::vector<LinkRecord>().swap(p);
    }
  }

  void refinement_pass() {
    const auto t0 = std::chrono::steady_clock::now();
    RefineCriterion criterion;
    criterion.feps = o_.feps * std::pow(4.0, double(o_.levels - 1 - level_));
    criterion.min_area = min_area_;
    criterion.seed = uint64_t(o_.seed);
    if (o_.refine == "bf") {
      criterion.radiosity = [this](const NodeKey& k) { return tree_.radiosity(k); };
      criterion.chart_reflectance = chart_reflectance_;
      // The scale: the scene's area-weighted mean radiosity now (largest channel), so a link is
      // refined when it would carry more than feps of the average radiosity.
      double weighted = 0.0, area = 0.0;
      for (size_t c = 0; c < charts_.size(); ++c) {
        const size_t root = tree_.chart_first[c];
        double top = 0.0;
        for (int ch = 0; ch < channels_; ++ch) top = std::max(top, tree_.b(ch, root));
        weighted += tree_.area[root] * top;
        area += tree_.area[root];
      }
      criterion.bf_scale = weighted > 0 ? weighted / area : 1.0;
    }
    const Refiner refiner(charts_, *visibility_, criterion,
                          clusters_.size() > 0 ? &clusters_ : nullptr);
    std::vector<LinkRecord> next;
    RefineStats stats;
    if (links_.empty() && passes_.empty() && clusters_.size() > 0) {
      // The root cluster with itself, opened into every cluster's pair of children (preorder):
      // each refined by one task into its own list, concatenated in order.
      const std::vector<std::pair<NodeKey, NodeKey>> frontier =
          Refiner::cluster_frontier(clusters_);
      std::vector<std::vector<LinkRecord>> parts(frontier.size());
      std::vector<RefineStats> part_stats(frontier.size());
      tbb::parallel_for(tbb::blocked_range<size_t>(0, frontier.size(), 1),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t k = r.begin(); k < r.end(); ++k)
                            refiner.refine_keys(frontier[k].first, frontier[k].second, parts[k],
                                                part_stats[k]);
                        });
      append_in_order(parts, next);
      for (const RefineStats& p : part_stats) stats.add(p);
    } else if (links_.empty() && passes_.empty()) {
      // Refine every pair of roots, grouped by the first root: results in a fixed order.
      const size_t n = charts_.size();
      std::vector<std::vector<LinkRecord>> parts(n);
      std::vector<RefineStats> part_stats(n);
      tbb::parallel_for(
          tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t a = r.begin(); a < r.end(); ++a)
              for (size_t b = a + 1; b < n; ++b)
                refiner.refine_roots(uint32_t(a), uint32_t(b), parts[a], part_stats[a]);
          });
      append_in_order(parts, next);
      for (const RefineStats& p : part_stats) stats.add(p);
    } else {
      constexpr size_t kBlock = 1024;
      const size_t blocks = (links_.size() + kBlock - 1) / kBlock;
      std::vector<std::vector<LinkRecord>> parts(blocks);
      std::vector<RefineStats> part_stats(blocks);
      tbb::parallel_for(
          tbb::blocked_range<size_t>(0, blocks, 1), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t k = r.begin(); k < r.end(); ++k)
              for (size_t l = k * kBlock; l < std::min(links_.size(), (k + 1) * kBlock); ++l)
                refiner.rerefine(links_[l], parts[k], part_stats[k]);
          });
      append_in_order(parts, next);
      for (const RefineStats& p : part_stats) stats.add(p);
    }
    links_ = std::move(next);
    counts_ = count_links(links_);
    Hierarchy tree = build_hierarchy(charts_, links_, &tree_, chart_emission_, chart_reflectance_,
                                     channels_, &clusters_);
    tree_ = std::move(tree);
    // Per-orientation push and pull through oriented clusters (hierarchical_hierarchy.h); the
    // column balance keeps the area-average ones its scaling is built on.
    if (o_.clustering == "oriented" && o_.rows != "balanced")
      enable_orientation_slots(tree_, charts_);
    counts_.max_depth = 0;
    for (const NodeKey& k : tree_.key)
      if (!k.is_cluster()) counts_.max_depth = std::max(counts_.max_depth, k.depth);
    RowStats rows;
    if (o_.rows != "links") rows = normalise_rows(tree_, charts_, o_.rows == "balanced");
    // Sinkhorn scaling meets row and column targets together only where the link pattern
    // allows it; where it does not, the columns stay off by the residual: say so.
    if (o_.rows == "balanced" && rows.balance_residual > 1e-6)
      log::warning(
          "hierarchical: rows=balanced: the columns did not reach their targets (largest "
          "relative miss " +
          text::format_double(rows.balance_residual) + " after " +
          std::to_string(rows.balance_rounds) +
          " rounds); the reflected light is conserved only to that");
    system_->charge_pair_evaluations(stats.pair_evaluations + rows.evaluations);
    system_->charge_rays(stats.rays);
    PassRecord record;
    record.feps = criterion.feps;
    record.stats = stats;
    record.rows = rows;
    record.nodes = tree_.size();
    record.leaves = tree_.leaves;
    record.links = links_.size();
    record.memory =
        tree_.memory_bytes() + links_.capacity() * sizeof(LinkRecord) + clusters_.memory_bytes();
    record.seconds = seconds_since(t0);
    record.peak_rss = peak_rss_bytes();
    passes_.push_back(record);
  }

  // The links' and nodes' counts that statistics() reports, taken once per refinement pass: the
  // runner asks for statistics at every checkpoint, and walking 8.5 M links each time was 7% of
  // a large run.
  struct LinkCounts {
    size_t visible = 0, partial = 0, cut = 0, with_a_cluster = 0, nonfinite_factors = 0;
    uint32_t max_depth = 0;
  };
  static LinkCounts count_links(const std::vector<LinkRecord>& links) {
    LinkCounts c;
    for (const LinkRecord& l : links) {
      if (l.cls == LinkClass::kCut)
        ++c.cut;
      else if (l.partial)
        ++c.partial;
      else
        ++c.visible;
      c.with_a_cluster += (l.p.is_cluster() || l.q.is_cluster()) ? 1 : 0;
      c.nonfinite_factors += (std::isfinite(l.fpq) ? 0 : 1) + (std::isfinite(l.fqp) ? 0 : 1);
    }
    return c;
  }

  HierarchicalOptions o_;
  LinkCounts counts_;
  const System* system_ = nullptr;
  std::vector<Chart> charts_;
  std::vector<ElementChart> elements_;
  ClusterTree clusters_;
  std::unique_ptr<NodeVisibility> visibility_;
  int channels_ = 1;
  std::vector<Rgb> chart_emission_, chart_reflectance_;
  double min_area_ = 0.0;
  std::vector<LinkRecord> links_;
  Hierarchy tree_;
  Radiosity solution_;
  std::vector<PassRecord> passes_;
  long long gather_passes_ = 0, level_ = 0, gathers_at_level_ = 0;
  double gather_seconds_ = 0.0;
  bool need_refine_ = true;
};

}  // namespace

SolverInfo hierarchical_solver_info() {
  return {"hierarchical",
          "hierarchical radiosity: quadtrees per polygon, links refined on estimated F (or BF) "
          "with ray-traced visibility triage; Jacobi or Gauss–Seidel gathers with push/pull; "
          "projected on the mesh",
          "Hanrahan, Salzman & Aupperle 1991",
          "one refinement pass or one gather + push/pull pass over all links",
          {{"feps", "", "link when both estimated form factors are below this (> 0)"},
           {"aeps", "", "smallest splittable node, as a fraction of the scene's total area (>= 0)"},
           {"refine", "", "refinement oracle: f (form factor) or bf (rho B F / mean B)"},
           {"levels", "", "multigrid levels: feps*4^(levels-1) ... feps (bf needs >= 2)"},
           {"gathers", "", "gather passes at each multigrid level but the last"},
           {"order", "", "gather order: jacobi or gauss-seidel"},
           {"rows", "",
            "leaf: each leaf's gathered light scaled to its own 2x2-rule row sum (<= 1); "
            "balanced: also the reflected light each leaf sends, so that its column (the power "
            "its light delivers) is that row sum too (Sinkhorn scaling: conserves power); links: "
            "the paper's unnormalised sum (diverges at rho near 1)"},
           {"seed", "", "seed of the visibility rays' jitter"},
           {"clustering", "",
            "none: refine every pair of polygons; isotropic: start from the root of a cluster "
            "hierarchy (Embree rtcBuildBVH) linked to itself, isotropic clusters (Smits et al. "
            "1994, Sillion 1995); oriented: the same with each cluster's projected area that of "
            "its polygons (up to 16 distinct normals exact, the rest isotropic), its light "
            "pushed and pulled per orientation"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<HierarchicalSolver>(HierarchicalOptions::from(bag));
          }};
}

}  // namespace radlab
